#include <gtest/gtest.h>

#include <cmath>

#include "die_cushion_ident/core/estimation/identification_config.h"

using namespace die_cushion_ident;

namespace {
bool mentions(const std::vector<std::string>& errors, const std::string& word) {
  for (const auto& e : errors) {
    if (e.find(word) != std::string::npos) return true;
  }
  return false;
}
}  // namespace

TEST(IdentificationConfig, DefaultsAreThePapersAndValid) {
  IdentificationConfig c;
  EXPECT_TRUE(c.validate().empty());
  EXPECT_EQ(c.moving_average_width, 31);
  EXPECT_EQ(c.derivative_width, 25);
  EXPECT_DOUBLE_EQ(c.resampler.sample_period, 0.002);
  EXPECT_DOUBLE_EQ(c.identification_period, 0.010);
  EXPECT_DOUBLE_EQ(c.forgetting_factor, 0.998);
  EXPECT_EQ(c.decimation(), 5);
}

TEST(IdentificationConfig, EveryInvalidValueIsNamedWithItsRange) {
  IdentificationConfig c;
  c.geometry.piston_area = -1.0;
  c.moving_average_width = 30;
  c.forgetting_factor = 1.5;
  c.identification_period = 0.003;  // not a multiple of 2 ms
  c.min_velocity = std::nan("");
  c.effects = {"leakage", "unicorns"};
  const auto errors = c.validate();
  EXPECT_TRUE(mentions(errors, "piston_area = -1 is invalid"));
  EXPECT_TRUE(mentions(errors, "moving_average_width = 30"));
  EXPECT_TRUE(mentions(errors, "forgetting_factor = 1.5"));
  EXPECT_TRUE(mentions(errors, "identification_period"));
  EXPECT_TRUE(mentions(errors, "min_velocity"));
  EXPECT_TRUE(mentions(errors, "unicorns"));
}

TEST(IdentificationConfig, InitialValuesMustBelongToTheModelAndBePlausible) {
  IdentificationConfig c;
  c.initial_parameters["bulk_modulus"] = -1e9;
  c.initial_parameters["leakage_conductance"] = 1e-11;  // leakage not active
  const auto errors = c.validate();
  EXPECT_TRUE(mentions(errors, "initial bulk_modulus"));
  EXPECT_TRUE(mentions(errors, "leakage_conductance"));
}

TEST(IdentificationConfig, BadCustomEffectIsReported) {
  IdentificationConfig c;
  c.custom_effects = {"relief=max(p -, 0)"};
  EXPECT_TRUE(mentions(c.validate(), "relief"));
}

TEST(IdentificationConfig, NumericKeysSetTheirFields) {
  IdentificationConfig c;
  EXPECT_TRUE(setNumericConfigValue(c, "forgetting_factor", 0.99));
  EXPECT_TRUE(setNumericConfigValue(c, "piston_area", 0.1));
  EXPECT_TRUE(setNumericConfigValue(c, "moving_average_width", 21));
  EXPECT_TRUE(setNumericConfigValue(c, "max_gap", 0.05));
  EXPECT_DOUBLE_EQ(c.forgetting_factor, 0.99);
  EXPECT_DOUBLE_EQ(c.geometry.piston_area, 0.1);
  EXPECT_EQ(c.moving_average_width, 21);
  EXPECT_DOUBLE_EQ(c.resampler.max_gap, 0.05);
  EXPECT_FALSE(setNumericConfigValue(c, "forgeting_factor", 0.99))
      << "unknown keys are reported, not ignored";
  EXPECT_TRUE(setNumericConfigValue(c, "derivative_width", 24.5));
  EXPECT_TRUE(mentions(c.validate(), "derivative_width")) << "a fractional width is invalid, not rounded";
  for (const auto& key : numericConfigKeys()) {
    IdentificationConfig d;
    EXPECT_TRUE(setNumericConfigValue(d, key, 1.0)) << key;
  }
}
