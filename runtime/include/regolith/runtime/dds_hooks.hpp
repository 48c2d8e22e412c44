#pragma once
// The runtime's seam to the DDS layer (runtime/dds): reading the `dds` section of a deployment and
// owning the participant's publisher thread.
#include <memory>
#include <string>

#include "regolith/core/params.hpp"

namespace regolith::dds {
class Participant;
}

namespace regolith::runtime {

/// Reads `dds: {enabled, domain, namespace}`; returns nullptr when disabled.
std::shared_ptr<dds::Participant> make_participant(Params& dds);
/// Declares the same parameters without creating anything (config check).
void declare_dds_params(Params& dds);
void start_participant(dds::Participant& p);
void stop_participant(dds::Participant& p);

}  // namespace regolith::runtime

namespace regolith::runtime {
/// One-line-per-topic summary of samples published / dropped (for the live summary).
std::string dds_summary(dds::Participant& p);
}  // namespace regolith::runtime
