#pragma once

#include <diagnostic_updater/diagnostic_updater.h>

#include "die_cushion_ident/core/monitoring/health_report.h"

namespace die_cushion_ident {

/// Copies a core health report into a diagnostic_updater status (HealthLevel has diagnostic_msgs' values).
inline void fill(diagnostic_updater::DiagnosticStatusWrapper& status, const HealthReport& report) {
  status.summary(static_cast<unsigned char>(report.level), report.message);
  for (const auto& [key, value] : report.values) status.add(key, value);
}

}  // namespace die_cushion_ident
