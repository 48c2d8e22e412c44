#pragma once
// The runtime's seam to the DDS layer (runtime/dds): reading the `dds` section of a deployment and
// owning the participant's publisher thread.
#include <memory>
#include <string>
#include <vector>

#include "regolith/core/params.hpp"
#include "regolith/core/time.hpp"

namespace regolith::dds {
class Participant;
}

namespace regolith::runtime {

/// Reads `dds: {enabled, domain, namespace}`; returns nullptr when disabled. `lossless` (simulated
/// time): stream writers keep all history so subscribers get every sample.
std::shared_ptr<dds::Participant> make_participant(Params& dds, bool lossless);
/// Declares the same parameters without creating anything (config check).
void declare_dds_params(Params& dds);
void start_participant(dds::Participant& p);
void stop_participant(dds::Participant& p);
/// Hand everything committed so far to DDS before simulated time moves on.
void sync_participant(dds::Participant& p);
/// Wait up to `timeout` for the writers of `topics` to have a matched reader; logs which have none.
void wait_for_readers(dds::Participant& p, const std::vector<std::string>& topics, TimeNs timeout);

}  // namespace regolith::runtime

namespace regolith::runtime {
/// One-line-per-topic summary of samples published / dropped (for the live summary).
std::string dds_summary(dds::Participant& p);
}  // namespace regolith::runtime
