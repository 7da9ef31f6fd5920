#include "lensim/util/svg.h"

#include <fmt/format.h>

#include "lensim/util/error.h"

namespace lensim::svg {

std::string escape(std::string_view s) {
  std::string out;
  out.reserve(s.size());
  for (char c : s) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&apos;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

std::string num(double v) {
  std::string s = fmt::format("{:.3f}", v);
  while (!s.empty() && s.back() == '0') s.pop_back();
  if (!s.empty() && s.back() == '.') s.pop_back();
  if (s == "-0") s = "0";
  return s;
}

Document::Document(double width, double height) : width_(width), height_(height) {}

void Document::element(std::string_view name, const Attrs& attrs, std::string_view body) {
  body_ += std::string(2 * (depth_ + 1), ' ');
  body_ += '<';
  body_ += name;
  for (const auto& [k, v] : attrs) body_ += fmt::format(" {}=\"{}\"", k, escape(v));
  if (body.empty()) {
    body_ += "/>\n";
  } else {
    body_ += '>';
    body_ += escape(body);
    body_ += fmt::format("</{}>\n", name);
  }
}

static Attrs concat(Attrs a, const Attrs& b) {
  a.insert(a.end(), b.begin(), b.end());
  return a;
}

void Document::rect(double x, double y, double w, double h, const Attrs& attrs) {
  element("rect",
          concat({{"x", num(x)}, {"y", num(y)}, {"width", num(w)}, {"height", num(h)}}, attrs));
}

void Document::line(double x1, double y1, double x2, double y2, const Attrs& attrs) {
  element("line",
          concat({{"x1", num(x1)}, {"y1", num(y1)}, {"x2", num(x2)}, {"y2", num(y2)}}, attrs));
}

void Document::circle(double cx, double cy, double r, const Attrs& attrs) {
  element("circle", concat({{"cx", num(cx)}, {"cy", num(cy)}, {"r", num(r)}}, attrs));
}

static std::string points(const std::vector<std::pair<double, double>>& pts) {
  std::string s;
  for (const auto& [x, y] : pts) {
    if (!s.empty()) s += ' ';
    s += num(x) + "," + num(y);
  }
  return s;
}

void Document::polyline(const std::vector<std::pair<double, double>>& pts, const Attrs& attrs) {
  element("polyline", concat({{"points", points(pts)}, {"fill", "none"}}, attrs));
}

void Document::polygon(const std::vector<std::pair<double, double>>& pts, const Attrs& attrs) {
  element("polygon", concat({{"points", points(pts)}}, attrs));
}

void Document::text(double x, double y, std::string_view content, const Attrs& attrs) {
  element("text", concat({{"x", num(x)}, {"y", num(y)}}, attrs), content);
}

void Document::beginGroup(const Attrs& attrs) {
  body_ += std::string(2 * (depth_ + 1), ' ') + "<g";
  for (const auto& [k, v] : attrs) body_ += fmt::format(" {}=\"{}\"", k, escape(v));
  body_ += ">\n";
  ++depth_;
}

void Document::endGroup() {
  if (depth_ == 0) return;
  --depth_;
  body_ += std::string(2 * (depth_ + 1), ' ') + "</g>\n";
}

void Document::title(std::string_view content) {
  element("title", {}, content);
}

std::string Document::str() const {
  std::string out = fmt::format(
      "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
      "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{}\" height=\"{}\" "
      "viewBox=\"0 0 {} {}\" font-family=\"DejaVu Sans, Helvetica, Arial, sans-serif\">\n",
      num(width_), num(height_), num(width_), num(height_));
  out += body_;
  for (int d = depth_; d > 0; --d) out += std::string(2 * d, ' ') + "</g>\n";
  out += "</svg>\n";
  return out;
}

}  // namespace lensim::svg
