#include "sim/estimator/settings.h"

#include <gtest/gtest.h>

#include "sim/estimator/presets.h"
#include "sim/scene/sequence.h"

namespace restir {
namespace {

TEST(Settings, RoundTripEveryFieldOfEveryPreset) {
  for (const Preset& p : AllPresets()) {
    PipelineSettings copy;  // defaults, then every field from the preset's printed values
    for (const auto& [key, value] : SettingsToStrings(p.settings)) ApplySetting(copy, key, value);
    EXPECT_EQ(SettingsToStrings(copy), SettingsToStrings(p.settings)) << p.name;
  }
}

TEST(Settings, OverrideChangesOnlyThatField) {
  PipelineSettings s = FindPreset("restir-unbiased")->settings;
  const auto before = SettingsToStrings(s);
  ApplySettingAssignment(s, "temporal.maxHistory=8");
  EXPECT_EQ(s.temporal.maxHistory, 8.0f);
  const auto after = SettingsToStrings(s);
  int changed = 0;
  for (size_t i = 0; i < before.size(); ++i) changed += before[i] != after[i];
  EXPECT_EQ(changed, 1);
  ApplySettingAssignment(s, "spatial.mis=balance");
  EXPECT_EQ(s.spatial.mis, MisFamily::kBalance);
  ApplySettingAssignment(s, "shade.visibility=wis-estimate");
  EXPECT_EQ(s.shade.visibility, VisibilityReuse::kWeighted);
}

TEST(Settings, UnknownKeySuggestsNearest) {
  PipelineSettings s;
  try {
    ApplySettingAssignment(s, "temporal.maxHistroy=8");
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("did you mean 'temporal.maxHistory'"), std::string::npos) << e.what();
  }
}

TEST(Settings, BadValuesAreInputErrors) {
  PipelineSettings s;
  EXPECT_THROW(ApplySettingAssignment(s, "temporal.maxHistory=-1"), InputError);
  EXPECT_THROW(ApplySettingAssignment(s, "temporal.maxHistory=nan"), InputError);
  EXPECT_THROW(ApplySettingAssignment(s, "spatial.mis=median"), InputError);
  EXPECT_THROW(ApplySettingAssignment(s, "temporal.enabled=maybe"), InputError);
  EXPECT_THROW(ApplySettingAssignment(s, "spatial.neighbours=99"), InputError);
  EXPECT_THROW(ApplySettingAssignment(s, "initial.candidates=0"), InputError);
  EXPECT_THROW(ApplySettingAssignment(s, "novalue"), InputError);
}

TEST(Presets, EveryDesignPresetExistsWithItsSource) {
  for (const char* name : {"ris", "temporal", "restir-biased", "restir-vis", "restir-wisvis", "restir-unbiased",
                           "restir-balance"}) {
    const Preset* p = FindPreset(name);
    ASSERT_NE(p, nullptr) << name;
    EXPECT_FALSE(p->source.empty());
  }
  // The unbiased presets use an unbiased family with ray-traced bias correction and no sample-dependent rejection.
  for (const char* name : {"restir-unbiased", "restir-balance"}) {
    const PipelineSettings& s = FindPreset(name)->settings;
    EXPECT_EQ(s.temporal.bias, BiasCorrection::kRayTraced);
    EXPECT_EQ(s.spatial.bias, BiasCorrection::kRayTraced);
    EXPECT_FALSE(s.temporal.sampleChecks);
  }
  EXPECT_NE(DescribePresets().find("temporal.maxHistory=20"), std::string::npos);
}

}  // namespace
}  // namespace restir
