#include "fleetmap/raster/png_canvas.h"

#include <cmath>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "fleetmap/core/error.h"
#include "fleetmap/images/image_codec.h"

namespace fleetmap {
namespace {

// OpenCV draws with integer coordinates unless told of fractional bits: 4 bits (1/16 px)
// keep anti-aliased lines and discs where the picture put them.
constexpr int kShift = 4;
constexpr double kOne = 1 << kShift;

cv::Point Fixed(CanvasPoint p) {
  return cv::Point(static_cast<int>(std::lround(p.x * kOne)),
                   static_cast<int>(std::lround(p.y * kOne)));
}

cv::Scalar Bgr(Rgb colour) {
  return cv::Scalar(colour.b, colour.g, colour.r);
}

int Thickness(double width_px) {
  return std::max(1, static_cast<int>(std::lround(width_px)));
}

}  // namespace

struct PngCanvas::Pixels {
  cv::Mat image;  // CV_8UC3, BGR
};

PngCanvas::PngCanvas() : pixels_(std::make_unique<Pixels>()) {}
PngCanvas::~PngCanvas() = default;

void PngCanvas::Begin(int width_px, int height_px, Rgb background) {
  pixels_->image = cv::Mat(std::max(1, height_px), std::max(1, width_px), CV_8UC3, Bgr(background));
}

void PngCanvas::BeginGroup(std::string_view /*name*/) {}
void PngCanvas::EndGroup() {}

void PngCanvas::Line(CanvasPoint from, CanvasPoint to, double width_px, Rgb colour) {
  cv::line(pixels_->image, Fixed(from), Fixed(to), Bgr(colour), Thickness(width_px), cv::LINE_AA,
           kShift);
}

void PngCanvas::Disc(CanvasPoint centre, double radius_px, Rgb fill, Rgb outline) {
  const int radius = static_cast<int>(std::lround(radius_px * kOne));
  cv::circle(pixels_->image, Fixed(centre), radius, Bgr(fill), cv::FILLED, cv::LINE_AA, kShift);
  cv::circle(pixels_->image, Fixed(centre), radius, Bgr(outline), 1, cv::LINE_AA, kShift);
}

void PngCanvas::Rectangle(CanvasPoint top_left, double width_px, double height_px,
                          std::optional<Rgb> fill, std::optional<Rgb> outline) {
  const cv::Point a = Fixed(top_left);
  const cv::Point b = Fixed({top_left.x + width_px, top_left.y + height_px});
  if (fill) cv::rectangle(pixels_->image, a, b, Bgr(*fill), cv::FILLED, cv::LINE_8, kShift);
  if (outline) cv::rectangle(pixels_->image, a, b, Bgr(*outline), 1, cv::LINE_8, kShift);
}

void PngCanvas::Text(CanvasPoint baseline, std::string_view text, double height_px, Rgb colour,
                     TextAnchor anchor) {
  constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;
  const int thickness = height_px >= 12.0 ? 2 : 1;
  const double scale = cv::getFontScaleFromHeight(kFont, static_cast<int>(height_px), thickness);
  std::string ascii(text);
  for (char& c : ascii) {
    if (static_cast<unsigned char>(c) < 0x20 || static_cast<unsigned char>(c) > 0x7e) c = '?';
  }
  int base = 0;
  const cv::Size size = cv::getTextSize(ascii, kFont, scale, thickness, &base);
  double x = baseline.x;
  if (anchor == TextAnchor::kMiddle) x -= size.width / 2.0;
  if (anchor == TextAnchor::kEnd) x -= size.width;
  cv::putText(
      pixels_->image, ascii,
      cv::Point(static_cast<int>(std::lround(x)), static_cast<int>(std::lround(baseline.y))), kFont,
      scale, Bgr(colour), thickness, cv::LINE_AA);
}

void PngCanvas::End() {}

std::string PngCanvas::EncodePng() const {
  if (pixels_->image.empty()) throw Error(ErrorCode::kBackend, "no picture to encode as PNG");
  return ::fleetmap::EncodePng(pixels_->image);
}

}  // namespace fleetmap
