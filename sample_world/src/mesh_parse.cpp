// Bounded OBJ / PLY / OFF readers (see mesh_parse.hpp).
#include "mesh_parse.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <new>

namespace world {

namespace {

/// A refusal inside a reader: caught in parseMeshBytes and turned into its message.
struct Refused {
  std::string message;
};

[[noreturn]] void refuse(std::string message) {
  throw Refused{std::move(message)};
}

std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%g", v);
  return buf;
}
std::string num(std::uint64_t v) {
  return std::to_string(v);
}

/// The token shown in a message: at most 40 bytes, non-printable bytes as '?'.
std::string shown(std::string_view t) {
  std::string out;
  for (const char c : t.substr(0, 40)) {
    out.push_back(c >= 0x20 && c < 0x7f ? c : '?');
  }
  if (t.size() > 40) out += "...";
  return "'" + out + "'";
}

bool isSpace(char c) {
  return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\f' || c == '\v';
}

bool parseDouble(std::string_view t, double& out) {
  if (!t.empty() && t[0] == '+') t.remove_prefix(1);
  if (t.empty()) return false;
  const auto r = std::from_chars(t.data(), t.data() + t.size(), out);
  return r.ec == std::errc() && r.ptr == t.data() + t.size();
}

bool parseInt(std::string_view t, std::int64_t& out) {
  if (!t.empty() && t[0] == '+') t.remove_prefix(1);
  if (t.empty()) return false;
  const auto r = std::from_chars(t.data(), t.data() + t.size(), out);
  return r.ec == std::errc() && r.ptr == t.data() + t.size();
}

/// Line-by-line view of the text, refusing a line longer than kMaxMeshLineBytes.
class Lines {
 public:
  explicit Lines(std::string_view data) : data_(data) {}
  bool next(std::string_view& line) {
    if (pos_ >= data_.size()) return false;
    const std::size_t end = data_.find('\n', pos_);
    const std::size_t stop = end == std::string_view::npos ? data_.size() : end;
    ++number_;
    if (stop - pos_ > kMaxMeshLineBytes) {
      refuse("line " + num(number_) + " is longer than the allowed " + num(kMaxMeshLineBytes) +
             " bytes");
    }
    line = data_.substr(pos_, stop - pos_);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    pos_ = stop + 1;
    return true;
  }
  [[nodiscard]] std::uint64_t number() const noexcept { return number_; }
  [[nodiscard]] std::size_t offset() const noexcept { return std::min(pos_, data_.size()); }

 private:
  std::string_view data_;
  std::size_t pos_ = 0;
  std::uint64_t number_ = 0;
};

/// Whitespace-separated tokens of one line (bounded by the line's length).
void split(std::string_view line, std::vector<std::string_view>& tokens) {
  tokens.clear();
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && isSpace(line[i])) ++i;
    const std::size_t start = i;
    while (i < line.size() && !isSpace(line[i])) ++i;
    if (i > start) tokens.push_back(line.substr(start, i - start));
  }
}

std::string_view stripComment(std::string_view line) {
  const std::size_t hash = line.find('#');
  return hash == std::string_view::npos ? line : line.substr(0, hash);
}

void addVertex(ParsedMesh& m, const std::array<double, 3>& p, const std::string& where) {
  if (m.vertexCount() >= kMaxMeshVertices) {
    refuse(where + ": more than the allowed " + num(kMaxMeshVertices) + " vertices");
  }
  static constexpr const char* kAxis[3] = {"x", "y", "z"};
  for (int a = 0; a < 3; ++a) {
    if (!std::isfinite(p[a])) {
      refuse(where + ": " + kAxis[a] + " = " + num(p[a]) + " is not a finite number");
    }
  }
  m.xyz.insert(m.xyz.end(), p.begin(), p.end());
}

/// Fan-triangulates a polygon of already checked indices.
void addPolygon(ParsedMesh& m, const std::vector<std::uint32_t>& poly, const std::string& where) {
  if (poly.size() < 3) {
    refuse(where + ": a face has " + num(std::uint64_t(poly.size())) +
           " vertices, allowed at least 3");
  }
  if (m.triangles.size() / 3 + (poly.size() - 2) > kMaxMeshTriangles) {
    refuse(where + ": more than the allowed " + num(kMaxMeshTriangles) + " triangles");
  }
  for (std::size_t k = 1; k + 1 < poly.size(); ++k) {
    m.triangles.push_back(poly[0]);
    m.triangles.push_back(poly[k]);
    m.triangles.push_back(poly[k + 1]);
  }
}

// ---- OBJ -------------------------------------------------------------------------------------

bool objKeywordIgnored(std::string_view k) {
  static constexpr std::array<std::string_view, 30> kIgnored = {
      "vt",     "vn",     "vp",       "l",        "p",    "o",         "g",    "s",
      "usemtl", "mtllib", "cstype",   "deg",      "bmat", "step",      "curv", "curv2",
      "surf",   "parm",   "trim",     "hole",     "scrv", "sp",        "end",  "con",
      "mg",     "bevel",  "c_interp", "d_interp", "lod",  "shadow_obj"};
  return std::find(kIgnored.begin(), kIgnored.end(), k) != kIgnored.end() || k == "trace_obj" ||
         k == "maplib" || k == "usemap" || k == "ctech" || k == "stech";
}

ParsedMesh parseObj(std::string_view data) {
  ParsedMesh m;
  Lines lines(data);
  std::string_view line;
  std::vector<std::string_view> tokens;
  std::vector<std::uint32_t> poly;
  while (lines.next(line)) {
    split(stripComment(line), tokens);
    if (tokens.empty()) continue;
    const std::string where = "line " + num(lines.number());
    const std::string_view key = tokens[0];
    if (key == "v") {
      // x y z, optionally w or r g b (ignored).
      if (tokens.size() < 4 || tokens.size() > 8) {
        refuse(where + ": a vertex has " + num(std::uint64_t(tokens.size() - 1)) +
               " numbers, allowed 3 to 7 ('v x y z [w | r g b]')");
      }
      std::array<double, 3> p{};
      for (std::size_t a = 1; a < tokens.size(); ++a) {
        double d = 0.0;
        if (!parseDouble(tokens[a], d))
          refuse(where + ": " + shown(tokens[a]) + " is not a number");
        if (a <= 3) p[a - 1] = d;
      }
      addVertex(m, p, where + " (vertex " + num(std::uint64_t(m.vertexCount() + 1)) + ")");
    } else if (key == "f") {
      poly.clear();
      if (tokens.size() - 1 > kMaxFaceVertices) {
        refuse(where + ": a face has " + num(std::uint64_t(tokens.size() - 1)) +
               " vertices, allowed at most " + num(kMaxFaceVertices));
      }
      const auto count = static_cast<std::int64_t>(m.vertexCount());
      for (std::size_t a = 1; a < tokens.size(); ++a) {
        // v, v/vt, v//vn or v/vt/vn: the vertex index comes first.
        const std::string_view t = tokens[a];
        const std::string_view v = t.substr(0, t.find('/'));
        std::int64_t idx = 0;
        if (v.empty()) {
          refuse(where + ": face token " + shown(t) +
                 " has no vertex index (allowed v, v/vt, v//vn, v/vt/vn)");
        }
        if (!parseInt(v, idx)) refuse(where + ": face index " + shown(v) + " is not an integer");
        const std::int64_t resolved = idx < 0 ? count + idx : idx - 1;
        if (idx == 0 || resolved < 0 || resolved >= count) {
          refuse(where + ": face index " + shown(v) + " is outside [1, " +
                 num(std::uint64_t(count)) + "] (or [-" + num(std::uint64_t(count)) +
                 ", -1]): the vertices defined so far");
        }
        poly.push_back(static_cast<std::uint32_t>(resolved));
      }
      addPolygon(m, poly, where);
    } else if (!objKeywordIgnored(key)) {
      refuse(where + ": unknown OBJ statement " + shown(key) +
             " (allowed v, f and the statements that are ignored: vt, vn, o, g, s, usemtl, "
             "mtllib, l, p, ...)");
    }
  }
  return m;
}

// ---- OFF -------------------------------------------------------------------------------------

/// Next line with content (comments stripped), split into tokens; false at the end.
bool nextContent(Lines& lines, std::vector<std::string_view>& tokens) {
  std::string_view line;
  while (lines.next(line)) {
    split(stripComment(line), tokens);
    if (!tokens.empty()) return true;
  }
  return false;
}

std::uint64_t count(std::string_view t, const std::string& what) {
  std::int64_t n = 0;
  if (!parseInt(t, n) || n < 0) {
    refuse(what + " = " + shown(t) + " is not a count (allowed an integer >= 0)");
  }
  return static_cast<std::uint64_t>(n);
}

ParsedMesh parseOff(std::string_view data) {
  static constexpr std::array<std::string_view, 8> kHeaders = {
      "OFF", "COFF", "NOFF", "CNOFF", "STOFF", "STCOFF", "STNOFF", "STCNOFF"};
  Lines lines(data);
  std::vector<std::string_view> tokens;
  if (!nextContent(lines, tokens)) refuse("no OFF header (the file has no content)");
  if (std::find(kHeaders.begin(), kHeaders.end(), tokens[0]) == kHeaders.end()) {
    refuse("not a valid OFF file: the first word " + shown(tokens[0]) +
           " is not an OFF header (allowed OFF, COFF, NOFF, CNOFF, STOFF, ...)");
  }
  tokens.erase(tokens.begin());
  if (!tokens.empty() && tokens[0] == "BINARY") refuse("binary OFF is not supported (ASCII only)");
  if (tokens.empty() && !nextContent(lines, tokens)) {
    refuse("truncated: the header has no vertex and face counts");
  }
  if (tokens.size() < 2 || tokens.size() > 3) {
    refuse("line " + num(lines.number()) +
           ": the counts line must hold 'vertices faces [edges]', it holds " +
           num(std::uint64_t(tokens.size())) + " values");
  }
  const std::uint64_t nv = count(tokens[0], "vertex count");
  const std::uint64_t nf = count(tokens[1], "face count");
  if (tokens.size() == 3) (void)count(tokens[2], "edge count");
  if (nv > kMaxMeshVertices) {
    refuse("vertex count = " + num(nv) + " is over the allowed " + num(kMaxMeshVertices));
  }
  if (nf > kMaxMeshTriangles) {
    refuse("face count = " + num(nf) + " is over the allowed " + num(kMaxMeshTriangles));
  }
  // A loose floor (every vertex and face line takes at least 2 bytes) checked before anything
  // is reserved; the lines themselves are checked below.
  const std::uint64_t left = data.size() - lines.offset();
  if (nv * 2 + nf * 2 > left + 1) {
    refuse("truncated: the header declares " + num(nv) + " vertices and " + num(nf) +
           " faces, which need at least " + num(nv * 2 + nf * 2) + " bytes; " + num(left) +
           " follow");
  }
  ParsedMesh m;
  m.xyz.reserve(static_cast<std::size_t>(nv) * 3);
  for (std::uint64_t v = 0; v < nv; ++v) {
    if (!nextContent(lines, tokens)) {
      refuse("truncated: the header declares " + num(nv) + " vertices, the file holds " + num(v));
    }
    const std::string where = "line " + num(lines.number()) + " (vertex " + num(v) + ")";
    if (tokens.size() < 3) {
      refuse(where + ": " + num(std::uint64_t(tokens.size())) + " numbers, allowed at least 3");
    }
    std::array<double, 3> p{};
    for (int a = 0; a < 3; ++a) {
      if (!parseDouble(tokens[a], p[a]))
        refuse(where + ": " + shown(tokens[a]) + " is not a number");
    }
    addVertex(m, p, where);
  }
  std::vector<std::uint32_t> poly;
  for (std::uint64_t f = 0; f < nf; ++f) {
    if (!nextContent(lines, tokens)) {
      refuse("truncated: the header declares " + num(nf) + " faces, the file holds " + num(f));
    }
    const std::string where = "line " + num(lines.number()) + " (face " + num(f) + ")";
    const std::uint64_t k = count(tokens[0], where + ": face vertex count");
    if (k < 3 || k > kMaxFaceVertices) {
      refuse(where + ": face vertex count = " + num(k) + ", allowed [3, " + num(kMaxFaceVertices) +
             "]");
    }
    if (tokens.size() - 1 < k) {
      refuse(where + ": declares " + num(k) + " vertices, the line holds " +
             num(std::uint64_t(tokens.size() - 1)) + " indices");
    }
    poly.clear();
    for (std::uint64_t a = 1; a <= k; ++a) {
      std::int64_t idx = 0;
      if (!parseInt(tokens[a], idx) || idx < 0 || static_cast<std::uint64_t>(idx) >= nv) {
        refuse(where + ": vertex index " + shown(tokens[a]) + " is outside [0, " +
               num(nv == 0 ? 0 : nv - 1) + "]");
      }
      poly.push_back(static_cast<std::uint32_t>(idx));
    }
    addPolygon(m, poly, where);
  }
  return m;
}

// ---- PLY -------------------------------------------------------------------------------------

enum class PlyType { kI8, kU8, kI16, kU16, kI32, kU32, kF32, kF64 };

std::optional<PlyType> plyType(std::string_view n) {
  if (n == "char" || n == "int8") return PlyType::kI8;
  if (n == "uchar" || n == "uint8") return PlyType::kU8;
  if (n == "short" || n == "int16") return PlyType::kI16;
  if (n == "ushort" || n == "uint16") return PlyType::kU16;
  if (n == "int" || n == "int32") return PlyType::kI32;
  if (n == "uint" || n == "uint32") return PlyType::kU32;
  if (n == "float" || n == "float32") return PlyType::kF32;
  if (n == "double" || n == "float64") return PlyType::kF64;
  return std::nullopt;
}

std::size_t plySize(PlyType t) {
  switch (t) {
    case PlyType::kI8:
    case PlyType::kU8:
      return 1;
    case PlyType::kI16:
    case PlyType::kU16:
      return 2;
    case PlyType::kI32:
    case PlyType::kU32:
    case PlyType::kF32:
      return 4;
    case PlyType::kF64:
      return 8;
  }
  return 8;
}

bool plyIsInteger(PlyType t) {
  return t != PlyType::kF32 && t != PlyType::kF64;
}

struct PlyProperty {
  std::string name;
  PlyType type = PlyType::kF32;
  bool list = false;
  PlyType countType = PlyType::kU8;
};

struct PlyElement {
  std::string name;
  std::uint64_t count = 0;
  std::vector<PlyProperty> properties;
};

enum class PlyFormat { kAscii, kLittle, kBig };

/// Reads the scalar values of the body, ASCII tokens or binary of either byte order.
class PlyBody {
 public:
  PlyBody(std::string_view body, PlyFormat format) : body_(body), format_(format) {}

  double read(PlyType t, const std::string& where) {
    if (format_ == PlyFormat::kAscii) {
      while (pos_ < body_.size() && isSpace(body_[pos_])) ++pos_;
      const std::size_t start = pos_;
      while (pos_ < body_.size() && !isSpace(body_[pos_])) ++pos_;
      const std::string_view tok = body_.substr(start, pos_ - start);
      if (tok.empty()) refuse("truncated: " + where + " is missing (the file ends)");
      double d = 0.0;
      if (plyIsInteger(t)) {
        std::int64_t i = 0;
        if (!parseInt(tok, i)) refuse(where + ": " + shown(tok) + " is not an integer");
        d = static_cast<double>(i);
      } else if (!parseDouble(tok, d)) {
        refuse(where + ": " + shown(tok) + " is not a number");
      }
      return d;
    }
    const std::size_t n = plySize(t);
    if (body_.size() - pos_ < n) refuse("truncated: " + where + " is missing (the file ends)");
    unsigned char b[8] = {};
    std::memcpy(b, body_.data() + pos_, n);
    pos_ += n;
    const bool hostLittle = [] {
      const std::uint16_t one = 1;
      unsigned char c = 0;
      std::memcpy(&c, &one, 1);
      return c == 1;
    }();
    if ((format_ == PlyFormat::kLittle) != hostLittle) std::reverse(b, b + n);
    switch (t) {
      case PlyType::kI8: {
        std::int8_t v;
        std::memcpy(&v, b, 1);
        return v;
      }
      case PlyType::kU8:
        return b[0];
      case PlyType::kI16: {
        std::int16_t v;
        std::memcpy(&v, b, 2);
        return v;
      }
      case PlyType::kU16: {
        std::uint16_t v;
        std::memcpy(&v, b, 2);
        return v;
      }
      case PlyType::kI32: {
        std::int32_t v;
        std::memcpy(&v, b, 4);
        return v;
      }
      case PlyType::kU32: {
        std::uint32_t v;
        std::memcpy(&v, b, 4);
        return v;
      }
      case PlyType::kF32: {
        float v;
        std::memcpy(&v, b, 4);
        return v;
      }
      case PlyType::kF64: {
        double v;
        std::memcpy(&v, b, 8);
        return v;
      }
    }
    return 0.0;
  }

  /// Bytes not yet read (an upper bound on what the rest can hold).
  [[nodiscard]] std::size_t left() const noexcept { return body_.size() - pos_; }
  [[nodiscard]] bool ascii() const noexcept { return format_ == PlyFormat::kAscii; }

 private:
  std::string_view body_;
  PlyFormat format_;
  std::size_t pos_ = 0;
};

/// A PLY header: the format and the elements with their properties.
struct PlyHeader {
  PlyFormat format = PlyFormat::kAscii;
  std::vector<PlyElement> elements;
};

/// Reads the header lines after "ply" up to and including "end_header" (refused: unknown
/// keywords, bad types or counts, more than kMaxPlyHeaderLines lines, no format line).
PlyHeader readPlyHeader(Lines& lines) {
  std::string_view line;
  std::vector<std::string_view> tokens;
  std::optional<PlyFormat> format;
  std::vector<PlyElement> elements;
  bool ended = false;
  while (!ended) {
    if (!lines.next(line)) refuse("truncated: the header has no 'end_header'");
    if (lines.number() > kMaxPlyHeaderLines) {
      refuse("the header is longer than the allowed " + num(kMaxPlyHeaderLines) + " lines");
    }
    split(line, tokens);
    const std::string where = "header line " + num(lines.number());
    if (tokens.empty() || tokens[0] == "comment" || tokens[0] == "obj_info") continue;
    if (tokens[0] == "end_header") {
      ended = true;
    } else if (tokens[0] == "format") {
      if (tokens.size() != 3 || tokens[2] != "1.0") {
        refuse(where + ": allowed 'format ascii|binary_little_endian|binary_big_endian 1.0'");
      }
      if (tokens[1] == "ascii")
        format = PlyFormat::kAscii;
      else if (tokens[1] == "binary_little_endian")
        format = PlyFormat::kLittle;
      else if (tokens[1] == "binary_big_endian")
        format = PlyFormat::kBig;
      else
        refuse(where + ": format " + shown(tokens[1]) +
               " (allowed ascii, binary_little_endian, binary_big_endian)");
    } else if (tokens[0] == "element") {
      if (tokens.size() != 3) refuse(where + ": allowed 'element NAME COUNT'");
      if (elements.size() >= 64) refuse(where + ": more than the allowed 64 elements");
      elements.push_back({std::string(tokens[1]), count(tokens[2], where + ": element count"), {}});
    } else if (tokens[0] == "property") {
      if (elements.empty()) refuse(where + ": a property before any element");
      if (elements.back().properties.size() >= 256) {
        refuse(where + ": more than the allowed 256 properties in one element");
      }
      PlyProperty p;
      if (tokens.size() == 5 && tokens[1] == "list") {
        const auto ct = plyType(tokens[2]), it = plyType(tokens[3]);
        if (!ct || !plyIsInteger(*ct) || !it) {
          refuse(where + ": list types " + shown(tokens[2]) + " " + shown(tokens[3]) +
                 " (the count must be an integer type)");
        }
        p = {std::string(tokens[4]), *it, true, *ct};
      } else if (tokens.size() == 3) {
        const auto t = plyType(tokens[1]);
        if (!t) {
          refuse(where + ": type " + shown(tokens[1]) +
                 " (allowed char, uchar, short, ushort, int, uint, float, double and the "
                 "int8..float64 names)");
        }
        p = {std::string(tokens[2]), *t, false, PlyType::kU8};
      } else {
        refuse(where + ": allowed 'property TYPE NAME' or 'property list COUNTTYPE TYPE NAME'");
      }
      elements.back().properties.push_back(p);
    } else {
      refuse(where + ": unknown header keyword " + shown(tokens[0]) +
             " (allowed format, element, property, comment, obj_info, end_header)");
    }
  }
  if (!format) refuse("the header has no 'format' line");
  return {*format, std::move(elements)};
}

ParsedMesh parsePly(std::string_view data) {
  Lines lines(data);
  std::string_view line;
  if (!lines.next(line) || line != "ply")
    refuse("not a valid PLY file: the first line is not 'ply'");
  const PlyHeader header = readPlyHeader(lines);
  const std::optional<PlyFormat> format = header.format;
  const std::vector<PlyElement>& elements = header.elements;
  const std::string_view body = data.substr(lines.offset());
  // Counts against the body's size before anything is allocated.
  std::uint64_t needed = 0;
  for (const PlyElement& e : elements) {
    std::uint64_t per = 0;
    for (const PlyProperty& p : e.properties) {
      per += *format == PlyFormat::kAscii ? 2 : plySize(p.list ? p.countType : p.type);
    }
    if (e.count > (std::uint64_t(1) << 40) ||
        (per > 0 && e.count * per > body.size() + 1 - needed)) {
      refuse("element '" + e.name + "' declares " + num(e.count) +
             " items, more than the file's remaining " + num(std::uint64_t(body.size())) +
             " bytes can hold (truncated or corrupt)");
    }
    needed = std::min<std::uint64_t>(needed + e.count * per, body.size() + 1);
  }
  PlyBody in(body, *format);
  ParsedMesh m;
  bool haveVertices = false, haveFaces = false;
  std::vector<std::uint32_t> poly;
  for (const PlyElement& e : elements) {
    const bool isVertex = e.name == "vertex", isFace = e.name == "face";
    int xyz[3] = {-1, -1, -1};
    int indices = -1;
    for (std::size_t k = 0; k < e.properties.size(); ++k) {
      const PlyProperty& p = e.properties[k];
      if (isVertex && !p.list) {
        if (p.name == "x") xyz[0] = int(k);
        if (p.name == "y") xyz[1] = int(k);
        if (p.name == "z") xyz[2] = int(k);
      }
      if (isFace && p.list && (p.name == "vertex_indices" || p.name == "vertex_index")) {
        indices = int(k);
      }
    }
    if (isVertex) {
      if (haveVertices) refuse("a second 'vertex' element");
      if (xyz[0] < 0 || xyz[1] < 0 || xyz[2] < 0) {
        refuse("the vertex element lacks one of the scalar properties x, y, z");
      }
      if (e.count > kMaxMeshVertices) {
        refuse("element vertex count = " + num(e.count) + " is over the allowed " +
               num(kMaxMeshVertices));
      }
      m.xyz.reserve(static_cast<std::size_t>(e.count) * 3);
      haveVertices = true;
    }
    if (isFace) {
      if (haveFaces) refuse("a second 'face' element");
      if (!haveVertices) refuse("the face element comes before the vertex element");
      if (indices < 0) refuse("the face element lacks a list property vertex_indices");
      if (e.count > kMaxMeshTriangles) {
        refuse("element face count = " + num(e.count) + " is over the allowed " +
               num(kMaxMeshTriangles));
      }
      haveFaces = true;
    }
    // Items without properties hold no data (and no byte bounds their count): nothing to read.
    if (e.properties.empty()) continue;
    for (std::uint64_t item = 0; item < e.count; ++item) {
      const std::string where = e.name + " " + num(item);
      std::array<double, 3> p{};
      poly.clear();
      for (std::size_t k = 0; k < e.properties.size(); ++k) {
        const PlyProperty& prop = e.properties[k];
        if (!prop.list) {
          const double v = in.read(prop.type, where + " property " + prop.name);
          for (int a = 0; a < 3; ++a) {
            if (isVertex && xyz[a] == int(k)) p[a] = v;
          }
          continue;
        }
        const double n = in.read(prop.countType, where + " list count of " + prop.name);
        const std::size_t itemBytes = in.ascii() ? 2 : plySize(prop.type);
        if (!(n >= 0) || n > double(in.left() / itemBytes) + 1) {
          refuse(where + ": list " + prop.name + " declares " + num(n) +
                 " items, more than the file's remaining bytes can hold");
        }
        const bool faceList = isFace && int(k) == indices;
        if (faceList && (n < 3 || n > double(kMaxFaceVertices))) {
          refuse(where + ": " + num(n) + " vertices, allowed [3, " + num(kMaxFaceVertices) + "]");
        }
        for (std::uint64_t i = 0; i < static_cast<std::uint64_t>(n); ++i) {
          const double v = in.read(prop.type, where + " " + prop.name + "[" + num(i) + "]");
          if (!faceList) continue;
          if (!(v >= 0) || v >= double(m.vertexCount()) || std::floor(v) != v) {
            refuse(where + ": vertex index " + num(v) + " is outside [0, " +
                   num(std::uint64_t(m.vertexCount() ? m.vertexCount() - 1 : 0)) + "]");
          }
          poly.push_back(static_cast<std::uint32_t>(v));
        }
      }
      if (isVertex) addVertex(m, p, where);
      if (isFace) addPolygon(m, poly, where);
    }
  }
  if (!haveVertices) refuse("no 'vertex' element");
  if (!haveFaces) refuse("no 'face' element");
  return m;
}

}  // namespace

std::optional<ParsedMesh> parseMeshBytes(std::string_view data, std::string_view format,
                                         std::string* error) {
  try {
    if (data.size() > kMaxMeshFileBytes) {
      refuse("the file has " + num(std::uint64_t(data.size())) + " bytes, allowed at most " +
             num(kMaxMeshFileBytes));
    }
    if (format == "obj") return parseObj(data);
    if (format == "off") return parseOff(data);
    if (format == "ply") return parsePly(data);
    refuse("unsupported format " + shown(format) + " (allowed obj, ply, off)");
  } catch (const Refused& r) {
    if (error) *error = r.message;
  } catch (const std::bad_alloc&) {
    if (error) *error = "out of memory while reading it";
  }
  return std::nullopt;
}

}  // namespace world
