// What a picture is drawn on: a few marks (lines, discs, rectangles, one-line text) in pixels,
// with one implementation per output format. A picture (map_picture.h) describes itself once,
// as calls on a Canvas, and every back end renders the same description: SvgCanvas
// (svg_canvas.h) writes SVG text, PngCanvas (fleetmap/raster/png_canvas.h) paints pixels.
//
// Conventions: coordinates in pixels, origin at the top left, x to the right, y down (as both
// SVG and images have it); colours are opaque 8-bit sRGB. Text is ASCII (raster fonts have no
// other glyphs) and one line; its height is the cap height's scale in pixels, and its
// position the start, middle or end of its baseline.
#pragma once

#include <cstdint>
#include <optional>
#include <string_view>

namespace fleetmap {

struct Rgb {
  std::uint8_t r = 0, g = 0, b = 0;

  friend bool operator==(const Rgb&, const Rgb&) = default;
};

struct CanvasPoint {
  double x = 0.0, y = 0.0;  // pixels
};

enum class TextAnchor { kStart, kMiddle, kEnd };

class Canvas {
 public:
  virtual ~Canvas() = default;

  // The first call: the picture's size and background. REQUIRES: both sizes >= 1.
  virtual void Begin(int width_px, int height_px, Rgb background) = 0;
  // The marks drawn until the matching EndGroup belong to one named part of the picture
  // ("nodes", "legend"): an SVG group with that id, nothing on a raster. Groups do not nest.
  virtual void BeginGroup(std::string_view name) = 0;
  virtual void EndGroup() = 0;
  virtual void Line(CanvasPoint from, CanvasPoint to, double width_px, Rgb colour) = 0;
  // A filled disc with a one-pixel outline.
  virtual void Disc(CanvasPoint centre, double radius_px, Rgb fill, Rgb outline) = 0;
  // An axis-aligned rectangle, filled and/or outlined (one pixel).
  virtual void Rectangle(CanvasPoint top_left, double width_px, double height_px,
                         std::optional<Rgb> fill, std::optional<Rgb> outline) = 0;
  virtual void Text(CanvasPoint baseline, std::string_view text, double height_px, Rgb colour,
                    TextAnchor anchor) = 0;
  // The last call: the picture is complete.
  virtual void End() = 0;
};

}  // namespace fleetmap
