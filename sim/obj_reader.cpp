#include "sim/obj_reader.h"

#include <charconv>
#include <cmath>
#include <map>
#include <sstream>
#include <string_view>
#include <vector>

#include "sim/text.h"

namespace restir {

Mesh ParseObjMesh(const std::string& bytes, const std::string& objPath, const std::string& origin) {
  auto fail = [&](int line, size_t column, const std::string& message) {
    throw InputError(OneLine(objPath + ":" + std::to_string(line) + ":" + std::to_string(column) +
                             ": error: " + message + origin));
  };

  std::vector<Vec3> positions, normals;
  struct Corner {
    int position;
    int normal;  // -1: none
  };
  std::vector<std::vector<Corner>> faces;
  std::istringstream in(bytes);
  std::string line;
  int lineNo = 0;
  while (std::getline(in, line)) {
    ++lineNo;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    // Tokens with their 1-based columns.
    std::vector<std::pair<std::string_view, size_t>> tokens;
    for (size_t i = 0; i < line.size();) {
      if (line[i] == '#') break;
      if (line[i] == ' ' || line[i] == '\t') {
        ++i;
        continue;
      }
      const size_t start = i;
      while (i < line.size() && line[i] != ' ' && line[i] != '\t' && line[i] != '#') ++i;
      tokens.emplace_back(std::string_view(line).substr(start, i - start), start + 1);
    }
    if (tokens.empty()) continue;
    const std::string_view cmd = tokens[0].first;
    auto number = [&](size_t t) {
      if (t >= tokens.size()) fail(lineNo, line.size() + 1, "expected a number");
      const std::string_view s = tokens[t].first;
      float v = 0.0f;
      const char* first = s.data() + (s.size() > 1 && s[0] == '+' ? 1 : 0);
      auto [ptr, ec] = std::from_chars(first, s.data() + s.size(), v);
      if (ec != std::errc() || ptr != s.data() + s.size() || !std::isfinite(v)) {
        fail(lineNo, tokens[t].second, "expected a number, got '" + std::string(s) + "'");
      }
      if (std::fabs(double(v)) > kMaxSequenceNumber)
        fail(lineNo, tokens[t].second, "number " + std::string(s) + " is beyond the limit of 1e+07 for a sequence's "
                                       "numbers (products of such numbers must stay finite in single precision)");
      return v;
    };
    if (cmd == "v" || cmd == "vn") {
      if (tokens.size() < 4 || tokens.size() > (cmd == "v" ? 5u : 4u)) {
        fail(lineNo, tokens[0].second, "'" + std::string(cmd) + "' needs 3 coordinates");
      }
      const Vec3 value(number(1), number(2), number(3));
      if (cmd == "v") {
        positions.push_back(value);
      } else {
        if (!(glm::length(value) > 0.0f)) fail(lineNo, tokens[1].second, "zero-length normal");
        normals.push_back(glm::normalize(value));
      }
    } else if (cmd == "f") {
      if (tokens.size() < 4) fail(lineNo, tokens[0].second, "a face needs at least 3 vertices");
      std::vector<Corner> face;
      for (size_t t = 1; t < tokens.size(); ++t) {
        const std::string_view tok = tokens[t].first;
        // Up to three '/'-separated indices: position, texture (ignored), normal.
        int idx[3] = {0, 0, 0};
        bool has[3] = {false, false, false};
        size_t field = 0, start = 0;
        for (size_t k = 0; k <= tok.size(); ++k) {
          if (k < tok.size() && tok[k] != '/') continue;
          if (field > 2) fail(lineNo, tokens[t].second, "bad face vertex '" + std::string(tok) + "'");
          const std::string_view part = tok.substr(start, k - start);
          if (!part.empty()) {
            auto [ptr, ec] = std::from_chars(part.data(), part.data() + part.size(), idx[field]);
            if (ec != std::errc() || ptr != part.data() + part.size() || idx[field] == 0) {
              fail(lineNo, tokens[t].second, "bad face vertex '" + std::string(tok) + "'");
            }
            has[field] = true;
          } else if (field == 0) {
            fail(lineNo, tokens[t].second, "bad face vertex '" + std::string(tok) + "'");
          }
          ++field;
          start = k + 1;
        }
        // OBJ indices are 1-based; negative ones count back from the latest element.
        auto resolve = [&](int index, size_t count, const char* what) {
          const long long r = index > 0 ? index - 1LL : static_cast<long long>(count) + index;
          if (r < 0 || r >= static_cast<long long>(count)) {
            fail(lineNo, tokens[t].second,
                 std::string(what) + " index " + std::to_string(index) + " out of range (" +
                     std::to_string(count) + " defined so far)");
          }
          return static_cast<int>(r);
        };
        Corner c{resolve(idx[0], positions.size(), "vertex"), -1};
        if (has[2]) c.normal = resolve(idx[2], normals.size(), "normal");
        face.push_back(c);
      }
      faces.push_back(std::move(face));
    }
  }
  if (faces.empty()) fail(std::max(lineNo, 1), 1, "the mesh has no faces");

  // Mesh normals are per vertex: split positions by (position, normal) pair when every corner has a normal,
  // otherwise use flat shading, since a partly-normalled mesh has no consistent per-vertex answer.
  bool allNormals = true;
  for (const auto& face : faces) {
    for (const Corner& c : face) allNormals = allNormals && c.normal >= 0;
  }
  Mesh mesh;
  std::map<std::pair<int, int>, uint32_t> vertexOf;
  auto vertex = [&](const Corner& c) {
    const std::pair<int, int> key(c.position, allNormals ? c.normal : -1);
    auto [it, inserted] = vertexOf.emplace(key, static_cast<uint32_t>(mesh.positions.size()));
    if (inserted) {
      mesh.positions.push_back(positions[c.position]);
      if (allNormals) mesh.normals.push_back(normals[c.normal]);
    }
    return it->second;
  };
  for (const auto& face : faces) {
    const uint32_t first = vertex(face[0]);
    for (size_t k = 1; k + 1 < face.size(); ++k)
      mesh.triangles.emplace_back(first, vertex(face[k]), vertex(face[k + 1]));
  }
  return mesh;
}

}  // namespace restir
