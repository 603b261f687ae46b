// A Canvas (fleetmap/interchange/canvas.h) that paints pixels with OpenCV and encodes them as
// PNG: `fleetmap render --out map.png`.
//
// Why a library of its own: OpenCV's image codecs bring GDAL and a hundred other shared
// libraries with them. The SVG back end (interchange) needs none of that, so fleetmapd, which
// draws its status page's picture as SVG, links interchange and not this.
//
// Lines and discs are anti-aliased; text uses OpenCV's Hershey sans-serif font (ASCII only:
// other bytes are drawn as '?'). Threading: one thread at a time; each PngCanvas draws one
// picture.
#pragma once

#include <memory>
#include <string>
#include <string_view>

#include "fleetmap/interchange/canvas.h"

namespace fleetmap {

class PngCanvas : public Canvas {
 public:
  PngCanvas();
  ~PngCanvas() override;

  void Begin(int width_px, int height_px, Rgb background) override;
  void BeginGroup(std::string_view name) override;
  void EndGroup() override;
  void Line(CanvasPoint from, CanvasPoint to, double width_px, Rgb colour) override;
  void Disc(CanvasPoint centre, double radius_px, Rgb fill, Rgb outline) override;
  void Rectangle(CanvasPoint top_left, double width_px, double height_px, std::optional<Rgb> fill,
                 std::optional<Rgb> outline) override;
  void Text(CanvasPoint baseline, std::string_view text, double height_px, Rgb colour,
            TextAnchor anchor) override;
  void End() override;

  // The picture as a PNG file's bytes. REQUIRES: End() was called. Throws Error(kBackend)
  // when OpenCV cannot encode it.
  std::string EncodePng() const;

 private:
  struct Pixels;
  std::unique_ptr<Pixels> pixels_;
};

}  // namespace fleetmap
