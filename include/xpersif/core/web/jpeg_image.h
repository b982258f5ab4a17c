/**
 * @file jpeg_image.h
 * @brief A raw camera image as JPEG, without ROS: what the Foxglove protocol's `<camera>/image_raw/compressed`
 *        channels carry (a raw 320×240 image is ~230 kB a frame; its JPEG a tenth of that or less).
 */
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace xpersif::core {

/// A raw image as sensor_msgs/Image holds it, not owned.
struct RawImageView {
  std::uint32_t width = 0;
  std::uint32_t height = 0;
  std::uint32_t step = 0;  ///< bytes per row
  std::string encoding;    ///< rgb8, bgr8, rgba8, bgra8 or mono8
  const std::uint8_t* data = nullptr;
  std::size_t size = 0;
};

/**
 * @brief @p image as JPEG of @p quality (1..100).
 * @throws ValidationError for another encoding, or a size that does not hold width × height pixels of it.
 */
std::vector<std::uint8_t> encodeJpeg(const RawImageView& image, int quality);

}  // namespace xpersif::core
