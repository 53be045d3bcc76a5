// Writing rendered images through OpenImageIO.
#pragma once

#include <span>
#include <string>

namespace raylab {

// `rgba` holds height rows of width linear RGBA pixels, the top row first. The format follows the
// extension: .png is written 8-bit with the sRGB curve (values clamped to [0, 1]), .exr as float.
// Throws std::runtime_error naming the path when it cannot be written.
void write_image(const std::string& path, std::span<const float> rgba, int width, int height);

// The sRGB transfer curve (IEC 61966-2-1) of a linear value clamped to [0, 1].
float srgb_encode(float linear);

}  // namespace raylab
