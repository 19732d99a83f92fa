#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace die_cushion_ident {

/// Severity of a health report; the values are diagnostic_msgs/DiagnosticStatus' OK, WARN and ERROR.
enum class HealthLevel : std::uint8_t { kOk = 0, kWarn = 1, kError = 2 };

/// One diagnostic's verdict as plain data: a level, a one-line message and key/value details. The live
/// diagnostics are pure functions to this type (tested without a roscore); the node copies it into a
/// diagnostic_updater status.
struct HealthReport {
  HealthLevel level = HealthLevel::kOk;
  std::string message;
  std::vector<std::pair<std::string, std::string>> values;

  void summary(HealthLevel l, std::string text) {
    level = l;
    message = std::move(text);
  }
  void add(std::string key, std::string value) { values.emplace_back(std::move(key), std::move(value)); }
  void add(std::string key, std::uint64_t value) { add(std::move(key), std::to_string(value)); }
  /// The value of `key`, or "" (for tests and tools).
  std::string value(const std::string& key) const {
    for (const auto& kv : values) {
      if (kv.first == key) return kv.second;
    }
    return "";
  }
};

}  // namespace die_cushion_ident
