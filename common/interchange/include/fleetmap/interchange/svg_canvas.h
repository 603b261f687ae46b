// A Canvas (canvas.h) that writes SVG 1.1 text: one element per mark (<line>, <circle>,
// <rect>, <text>) inside <g id="NAME"> for each group, an XML declaration and no DOCTYPE.
// Coordinates are written to 0.1 px: finer than any screen shows, and a large map's file stays
// about 80 bytes per mark. Text is XML-escaped.
//
// Threading: one thread at a time; each SvgCanvas draws one picture.
#pragma once

#include <string>
#include <string_view>

#include "fleetmap/interchange/canvas.h"

namespace fleetmap {

class SvgCanvas : public Canvas {
 public:
  // `title` becomes the document's <title> (what a browser shows for the picture).
  explicit SvgCanvas(std::string_view title = {});

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

  // The document. REQUIRES: End() was called.
  const std::string& svg() const { return svg_; }

 private:
  std::string title_;
  std::string svg_;
};

}  // namespace fleetmap
