#include "sim/presets.h"

#include <sstream>

namespace restir {

const std::vector<Preset>& AllPresets() {
  static const std::vector<Preset> presets = [] {
    std::vector<Preset> p;
    {
      Preset ris;
      ris.name = "ris";
      ris.description = "no reuse: streaming RIS over 32 power-sampled light candidates, one final shadow ray";
      ris.source = "seed 003 §1 (baseline); Talbot et al. 2005";
      ris.settings.initial.candidates = 32;
      ris.settings.initial.lightSelection = LightSelection::kPower;
      ris.settings.initial.initialVisibility = false;
      ris.settings.shade.finalVisibility = true;
      p.push_back(ris);
    }
    return p;
  }();
  return presets;
}

const Preset* FindPreset(const std::string& name) {
  for (const Preset& p : AllPresets())
    if (p.name == name) return &p;
  return nullptr;
}

std::string DescribePresets() {
  std::ostringstream o;
  for (const Preset& p : AllPresets()) {
    const PipelineSettings& s = p.settings;
    o << p.name << "\n  " << p.description << "\n  source: " << p.source << "\n"
      << "  initial.candidates=" << s.initial.candidates
      << " initial.lightSelection=" << (s.initial.lightSelection == LightSelection::kPower ? "power" : "uniform")
      << " initial.visibility=" << (s.initial.initialVisibility ? "on" : "off")
      << " shade.finalVisibility=" << (s.shade.finalVisibility ? "on" : "off") << "\n";
  }
  return o.str();
}

}  // namespace restir
