// A small SVG writer. lensim's pictures (lens diagrams, plots) are SVG: crisp, diff-able, and
// readable by every browser. Written here because output needs no XML library: elements are
// appended as text with escaped attribute values, and the document is closed by str().
#pragma once

#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace lensim::svg {

/// Escapes &, <, >, " and ' for use in text and attribute values.
std::string escape(std::string_view s);

/// Formats a coordinate compactly (3 decimals, no trailing zeros).
std::string num(double v);

/// Attribute list: name/value pairs, values escaped when written.
using Attrs = std::vector<std::pair<std::string, std::string>>;

/// An SVG document under construction. Coordinates are in user units (pixels).
class Document {
 public:
  Document(double width, double height);

  void rect(double x, double y, double w, double h, const Attrs& attrs = {});
  void line(double x1, double y1, double x2, double y2, const Attrs& attrs = {});
  void circle(double cx, double cy, double r, const Attrs& attrs = {});
  /// Open polyline through the points.
  void polyline(const std::vector<std::pair<double, double>>& pts, const Attrs& attrs = {});
  /// Closed polygon through the points.
  void polygon(const std::vector<std::pair<double, double>>& pts, const Attrs& attrs = {});
  void text(double x, double y, std::string_view content, const Attrs& attrs = {});
  /// Groups: everything until endGroup() goes inside.
  void beginGroup(const Attrs& attrs = {});
  void endGroup();
  /// A <title> child (tooltip / accessible name) for the current group.
  void title(std::string_view content);

  double width() const { return width_; }
  double height() const { return height_; }

  /// The complete document text.
  std::string str() const;

 private:
  void element(std::string_view name, const Attrs& attrs, std::string_view body = {});
  double width_, height_;
  std::string body_;
  int depth_ = 0;
};

}  // namespace lensim::svg
