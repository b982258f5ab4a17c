#include "xpersif/core/web/jpeg_image.h"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <map>

#include "xpersif/core/common/validation.h"

namespace xpersif::core {

namespace {

struct Layout {
  int type;
  int channels;
  int to_bgr;  ///< cv::cvtColor code; -1: none needed
};

const std::map<std::string, Layout>& layouts() {
  static const std::map<std::string, Layout> table{{"bgr8", {CV_8UC3, 3, -1}},
                                                   {"rgb8", {CV_8UC3, 3, cv::COLOR_RGB2BGR}},
                                                   {"bgra8", {CV_8UC4, 4, cv::COLOR_BGRA2BGR}},
                                                   {"rgba8", {CV_8UC4, 4, cv::COLOR_RGBA2BGR}},
                                                   {"mono8", {CV_8UC1, 1, -1}}};
  return table;
}

}  // namespace

std::vector<std::uint8_t> encodeJpeg(const RawImageView& image, int quality) {
  requireInRange("JPEG quality", quality, 1, 100);
  auto it = layouts().find(image.encoding);
  if (it == layouts().end()) {
    throw ValidationError("cannot make a JPEG of a '" + image.encoding + "' image (rgb8, bgr8, rgba8, bgra8, mono8)");
  }
  const Layout& layout = it->second;
  const std::size_t row = std::size_t{image.width} * layout.channels;
  if (image.width == 0 || image.height == 0 || image.step < row ||
      image.size < std::size_t{image.step} * image.height || image.data == nullptr) {
    throw ValidationError("a " + std::to_string(image.width) + "x" + std::to_string(image.height) + " " +
                          image.encoding + " image of step " + std::to_string(image.step) + " cannot be " +
                          std::to_string(image.size) + " bytes");
  }
  // The message's bytes are only read: cv::Mat wraps them without a copy.
  const cv::Mat raw(static_cast<int>(image.height), static_cast<int>(image.width), layout.type,
                    const_cast<std::uint8_t*>(image.data), image.step);
  cv::Mat bgr = raw;
  if (layout.to_bgr >= 0) cv::cvtColor(raw, bgr, layout.to_bgr);
  std::vector<std::uint8_t> jpeg;
  cv::imencode(".jpg", bgr, jpeg, {cv::IMWRITE_JPEG_QUALITY, quality});
  return jpeg;
}

}  // namespace xpersif::core
