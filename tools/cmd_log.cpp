// regolith log info FILE.mcap: what an MCAP recording holds (record/README.md): profile, library,
// channels with their message counts, time range, chunks and compression, attachments, metadata;
// "truncated at byte N" for a file cut off mid-write (the complete part is still read).
// A file that is not MCAP, or whose data is damaged (CRC mismatch, undecodable chunk), ends with
// an error naming the file and the byte offset (exit status 2, bad input).
#include <cstdio>
#include <memory>
#include <string>

#include "cli.hpp"
#include "regolith/core/error.hpp"
#include "regolith/record/info.hpp"
#include "regolith/record/mcap_reader.hpp"

namespace regolith::cli {
namespace {

struct LogInfoArgs {
  std::string file;
  bool scan = false;
};

const bool registered = add_command([](CLI::App& app) {
  CLI::App* log = group(app, "log", "inspect MCAP recordings");
  auto a = std::make_shared<LogInfoArgs>();
  CLI::App* info = log->add_subcommand("info", "channels, message counts, time range and chunks of an MCAP file");
  info->add_option("file", a->file, "MCAP file")->required();
  info->add_flag("--scan", a->scan, "read every chunk (decompress, check CRCs, count) instead of trusting the summary");
  info->callback([a] {
    record::McapReaderOptions o;
    o.use_summary = !a->scan;
    record::McapReader reader(a->file, o);  // InputError "FILE: byte N: ..." when not MCAP
    std::fputs(record::format_info(reader.info()).c_str(), stdout);
    std::fflush(stdout);
    if (!reader.info().problems.empty()) throw InputError(reader.describe(reader.info().problems.front()));
  });
});

}  // namespace
}  // namespace regolith::cli
