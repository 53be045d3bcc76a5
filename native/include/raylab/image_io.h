// Writing rendered images, and reading image files back by channel, through OpenImageIO.
#pragma once

#include <span>
#include <string>
#include <vector>

namespace raylab {

// `rgba` holds height rows of width linear RGBA pixels, the top row first. The format follows the
// extension: .png is written 8-bit with the sRGB curve (values clamped to [0, 1]), .exr as float.
// Throws std::runtime_error naming the path when it cannot be written, std::invalid_argument (how many
// pixels, and where the first is) when a channel of a pixel is NaN or infinite.
void write_image(const std::string& path, std::span<const float> rgba, int width, int height);

// Every channel of an image file (its first subimage) as float, by the file's channel names: a
// multilayer EXR's "ViewLayer.Combined.R", "ViewLayer.raylab Box Tests.X", ...
struct ImageChannels {
  int width = 0, height = 0;
  std::vector<std::string> names;
  std::vector<float> pixels;  // height rows of width pixels of names.size() channels, the top row first
};
// Throws std::runtime_error naming the path when it cannot be read.
ImageChannels read_channels(const std::string& path);

// The sRGB transfer curve (IEC 61966-2-1) of a linear value clamped to [0, 1].
float srgb_encode(float linear);

}  // namespace raylab
