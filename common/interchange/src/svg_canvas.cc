#include "fleetmap/interchange/svg_canvas.h"

#include <cmath>
#include <cstdio>

#include "fleetmap/core/printable_text.h"

namespace fleetmap {
namespace {

// A coordinate or length to 0.1 px, without a trailing ".0".
void AppendPixels(std::string& out, double value) {
  const double tenths = std::round(value * 10.0);
  char text[32];
  if (std::fmod(tenths, 10.0) == 0.0) {
    std::snprintf(text, sizeof text, "%.0f", tenths / 10.0);
  } else {
    std::snprintf(text, sizeof text, "%.1f", tenths / 10.0);
  }
  out += text;
}

void AppendAttribute(std::string& out, std::string_view name, double value) {
  out += ' ';
  out += name;
  out += "=\"";
  AppendPixels(out, value);
  out += '"';
}

std::string Hex(Rgb colour) {
  char text[8];
  std::snprintf(text, sizeof text, "#%02x%02x%02x", colour.r, colour.g, colour.b);
  return text;
}

}  // namespace

SvgCanvas::SvgCanvas(std::string_view title) : title_(title) {}

void SvgCanvas::Begin(int width_px, int height_px, Rgb background) {
  svg_ = "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<svg xmlns=\"http://www.w3.org/2000/svg\"";
  AppendAttribute(svg_, "width", width_px);
  AppendAttribute(svg_, "height", height_px);
  svg_ += " viewBox=\"0 0 " + std::to_string(width_px) + " " + std::to_string(height_px) +
          "\" font-family=\"DejaVu Sans, Arial, sans-serif\">\n<title>";
  AppendMarkupEscaped(svg_, title_);
  svg_ += "</title>\n<rect x=\"0\" y=\"0\" width=\"100%\" height=\"100%\" fill=\"" +
          Hex(background) + "\"/>\n";
}

void SvgCanvas::BeginGroup(std::string_view name) {
  svg_ += "<g id=\"";
  AppendMarkupEscaped(svg_, name);
  svg_ += "\">\n";
}

void SvgCanvas::EndGroup() {
  svg_ += "</g>\n";
}

void SvgCanvas::Line(CanvasPoint from, CanvasPoint to, double width_px, Rgb colour) {
  svg_ += "<line";
  AppendAttribute(svg_, "x1", from.x);
  AppendAttribute(svg_, "y1", from.y);
  AppendAttribute(svg_, "x2", to.x);
  AppendAttribute(svg_, "y2", to.y);
  svg_ += " stroke=\"" + Hex(colour) + "\"";
  AppendAttribute(svg_, "stroke-width", width_px);
  svg_ += "/>\n";
}

void SvgCanvas::Disc(CanvasPoint centre, double radius_px, Rgb fill, Rgb outline) {
  svg_ += "<circle";
  AppendAttribute(svg_, "cx", centre.x);
  AppendAttribute(svg_, "cy", centre.y);
  AppendAttribute(svg_, "r", radius_px);
  svg_ += " fill=\"" + Hex(fill) + "\" stroke=\"" + Hex(outline) + "\"/>\n";
}

void SvgCanvas::Rectangle(CanvasPoint top_left, double width_px, double height_px,
                          std::optional<Rgb> fill, std::optional<Rgb> outline) {
  svg_ += "<rect";
  AppendAttribute(svg_, "x", top_left.x);
  AppendAttribute(svg_, "y", top_left.y);
  AppendAttribute(svg_, "width", width_px);
  AppendAttribute(svg_, "height", height_px);
  svg_ += " fill=\"" + (fill ? Hex(*fill) : std::string("none")) + "\"";
  if (outline) svg_ += " stroke=\"" + Hex(*outline) + "\"";
  svg_ += "/>\n";
}

void SvgCanvas::Text(CanvasPoint baseline, std::string_view text, double height_px, Rgb colour,
                     TextAnchor anchor) {
  svg_ += "<text";
  AppendAttribute(svg_, "x", baseline.x);
  AppendAttribute(svg_, "y", baseline.y);
  // height_px is the cap height; a sans-serif font's capitals are about 0.72 of its size.
  AppendAttribute(svg_, "font-size", height_px / 0.72);
  svg_ += " fill=\"" + Hex(colour) + "\"";
  if (anchor == TextAnchor::kMiddle) svg_ += " text-anchor=\"middle\"";
  if (anchor == TextAnchor::kEnd) svg_ += " text-anchor=\"end\"";
  svg_ += '>';
  AppendMarkupEscaped(svg_, text);
  svg_ += "</text>\n";
}

void SvgCanvas::End() {
  svg_ += "</svg>\n";
}

}  // namespace fleetmap
