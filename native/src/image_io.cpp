#include "raylab/image_io.h"

#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <vector>

namespace raylab {

float srgb_encode(float linear) {
  const float c = linear > 0.0f ? std::min(linear, 1.0f) : 0.0f;  // NaN becomes 0
  return c <= 0.0031308f ? 12.92f * c : 1.055f * std::pow(c, 1.0f / 2.4f) - 0.055f;
}

void write_image(const std::string& path, std::span<const float> rgba, int width, int height) {
  const auto fail = [&](const std::string& why) {
    throw std::runtime_error("cannot write image '" + path + "': " + why);
  };
  if (width <= 0 || height <= 0 || rgba.size() != size_t(width) * size_t(height) * 4)
    fail("the image must be (height, width, 4) with height, width > 0");
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  if (ext != ".png" && ext != ".exr") fail("the extension must be .png or .exr");
  // A NaN or an infinity is no colour: PNG would write it as black or white and EXR keep it, and the
  // picture would look fine or broken with no word of why.
  size_t bad = 0, first = 0;
  for (size_t p = 0; p < size_t(width) * size_t(height); ++p)
    if (!std::all_of(&rgba[4 * p], &rgba[4 * p] + 4, [](float c) { return std::isfinite(c); }) && bad++ == 0) first = p;
  if (bad > 0)
    throw std::invalid_argument("cannot write image '" + path + "': " + std::to_string(bad) + " of its " +
                                std::to_string(size_t(width) * size_t(height)) +
                                " pixels are not finite (NaN or infinite), the first at row " +
                                std::to_string(first / size_t(width)) + ", column " +
                                std::to_string(first % size_t(width)) + " (row 0 the top row)");

  auto out = OIIO::ImageOutput::create(path);
  if (!out) fail(OIIO::geterror());
  bool ok;
  if (ext == ".png") {
    std::vector<uint8_t> bytes(rgba.size());
    for (size_t i = 0; i < rgba.size(); ++i) {
      // Alpha is not colour: it is stored linearly.
      const float v = (i % 4 == 3) ? (rgba[i] > 0.0f ? std::min(rgba[i], 1.0f) : 0.0f) : srgb_encode(rgba[i]);
      bytes[i] = uint8_t(std::lround(v * 255.0f));
    }
    OIIO::ImageSpec spec(width, height, 4, OIIO::TypeDesc::UINT8);
    spec.attribute("oiio:ColorSpace", "sRGB");
    ok = out->open(path, spec) && out->write_image(OIIO::TypeDesc::UINT8, bytes.data());
  } else {
    OIIO::ImageSpec spec(width, height, 4, OIIO::TypeDesc::FLOAT);
    spec.attribute("oiio:ColorSpace", "Linear");
    ok = out->open(path, spec) && out->write_image(OIIO::TypeDesc::FLOAT, rgba.data());
  }
  if (!ok) fail(out->geterror());
  if (!out->close()) fail(out->geterror());
}

ImageChannels read_channels(const std::string& path) {
  auto in = OIIO::ImageInput::open(path);
  if (!in) throw std::runtime_error("cannot read image '" + path + "': " + OIIO::geterror());
  const OIIO::ImageSpec& spec = in->spec();
  ImageChannels out;
  out.width = spec.width;
  out.height = spec.height;
  out.names = spec.channelnames;
  out.pixels.resize(size_t(spec.width) * size_t(spec.height) * size_t(spec.nchannels));
  if (!in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, out.pixels.data()))
    throw std::runtime_error("cannot read image '" + path + "': " + in->geterror());
  in->close();
  return out;
}

}  // namespace raylab
