#pragma once

#include <string>
#include <vector>

#include "output/analysis_writer.h"

namespace die_cushion_ident {

/// analyze_bag's summary.yaml at `path`: the input, the settings, the model, the fit, the ranking, the
/// verdicts and warnings of `result`, and the files of the run (`outputs`). A figure that is not finite is
/// written as null (~), with a warning that says so.
void writeSummary(const std::string& path, const AnalysisInput& input, const IdentificationConfig& config,
                  const OfflineResult& result, const std::vector<std::string>& outputs);

}  // namespace die_cushion_ident
