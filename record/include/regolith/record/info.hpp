#pragma once
// The text `regolith log info FILE.mcap` prints for an opened file.
#include <string>

#include "regolith/record/mcap_reader.hpp"

namespace regolith::record {

/// Profile, library, messages, time range and duration, chunks and compression, one line per
/// channel (id, topic, schema, encoding, count), attachments, metadata, then "truncated at byte N"
/// and one line per problem ("damaged: byte N: ...") when there are any.
std::string format_info(const McapFileInfo& info);

}  // namespace regolith::record
