#pragma once
// The acceptance criteria of the experiments file judged on what the report's runs left and
// on the trial results given: `rollstep report` prints this verdict, --check exits on it and
// the document shows it.
#include <vector>

#include "report_document.hpp"
#include "runs.hpp"

namespace rollstep::experiments {

/// On the runs, each Table 1 margin of the candidate against the baseline (both must pass,
/// with metrics, to be compared); the speed sweep's ratios; on the trials given, the
/// candidate's success rate. outcomes[i] is the run of in.set.scenarios[i].
ReportVerdict judgeAcceptance(const ReportInputs& in, const std::vector<RunOutcome>& outcomes);

}  // namespace rollstep::experiments
