// What the sweep tests share: reading a file whole, and sweep.csv without the columns that are timings.
#pragma once

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace restir::test {

inline std::string ReadText(const std::filesystem::path& p) {
  std::ifstream f(p, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
}

// A CSV without the columns that are timings or decided by them (ms_*, efficiency, pareto) and reference_cached
// (whether this process or another rendered the frame's reference): what a merge must reproduce to the byte.
inline std::string WithoutTimings(const std::string& csv) {
  std::istringstream in(csv);
  std::string out, line;
  std::vector<bool> keep;
  while (std::getline(in, line)) {
    std::vector<std::string> fields;
    std::string f;
    std::istringstream ls(line + ",");
    while (std::getline(ls, f, ',')) fields.push_back(f);
    if (keep.empty())
      for (const std::string& name : fields)
        keep.push_back(name.rfind("ms_", 0) != 0 && name != "efficiency" && name != "pareto" &&
                       name != "reference_cached");
    for (size_t k = 0; k < fields.size() && k < keep.size(); ++k)
      if (keep[k]) out += fields[k] + ",";
    out += "\n";
  }
  return out;
}

}  // namespace restir::test
