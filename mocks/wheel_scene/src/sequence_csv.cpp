// Sequence CSV: `frame,encoder_angle_rad,truth_mm`.
#include <cmath>
#include <cstdio>
#include <fstream>
#include <stdexcept>
#include <string>

#include <opencv2/imgcodecs.hpp>

#include "regolith/core/csv.hpp"
#include "regolith/core/text_file.hpp"
#include "regolith/wheel_scene/wheel_scene.hpp"

namespace regolith::wheel_scene {
namespace {

double parse_number(const std::string& text, const std::filesystem::path& file, int line, const char* column) {
  const std::string t = trim_blanks(text);
  std::size_t used = 0;
  double v = 0;
  try {
    v = std::stod(t, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (t.empty() || used != t.size() || !std::isfinite(v)) {
    throw std::runtime_error(file.string() + ":" + std::to_string(line) + ": column " + column +
                             ": expected a finite number (got '" + t + "')");
  }
  return v;
}

}  // namespace

void write_sequence_csv(const std::filesystem::path& csv, const std::vector<SequenceRow>& rows,
                        const std::vector<std::string>& comments) {
  std::ofstream os(csv);
  if (!os) throw std::runtime_error(csv.string() + ": cannot open for writing");
  for (const auto& c : comments) {
    if (c.find('\n') != std::string::npos) throw std::runtime_error(csv.string() + ": comment contains a line break");
    os << "# " << c << '\n';
  }
  os << "frame,encoder_angle_rad,truth_mm\n";
  char buf[64];
  for (const auto& r : rows) {
    if (r.frame.find(',') != std::string::npos) {
      throw std::runtime_error(csv.string() + ": frame name contains a comma: " + r.frame);
    }
    os << r.frame << ',';
    std::snprintf(buf, sizeof buf, "%.9g,%.6f", r.encoder_angle_rad, r.truth_mm);
    os << buf << '\n';
  }
  close_output(os, csv.string(), "the sequence CSV");
}

std::vector<SequenceRow> read_sequence_csv(const std::filesystem::path& csv) {
  std::ifstream is(csv);
  if (!is) throw std::runtime_error(csv.string() + ": cannot open");
  std::string line;
  int n = 0;
  std::vector<SequenceRow> rows;
  bool header = false;
  while (std::getline(is, line)) {
    ++n;
    const std::string t = trim_blanks(line);
    if (t.empty() || t[0] == '#') continue;
    const std::vector<std::string> cols = split_csv_line(t);
    if (!header) {
      if (cols.size() != 3 || cols[0] != "frame" || cols[1] != "encoder_angle_rad" || cols[2] != "truth_mm") {
        throw std::runtime_error(csv.string() + ":" + std::to_string(n) +
                                 ": expected header 'frame,encoder_angle_rad,truth_mm' (got '" + t + "')");
      }
      header = true;
      continue;
    }
    if (cols.size() != 3) {
      throw std::runtime_error(csv.string() + ":" + std::to_string(n) + ": expected 3 columns (got " +
                               std::to_string(cols.size()) + ")");
    }
    if (cols[0].empty()) {
      throw std::runtime_error(csv.string() + ":" + std::to_string(n) + ": column frame: empty");
    }
    SequenceRow r;
    r.line = n;
    r.frame = cols[0];
    r.encoder_angle_rad = parse_number(cols[1], csv, n, "encoder_angle_rad");
    r.truth_mm = parse_number(cols[2], csv, n, "truth_mm");
    rows.push_back(std::move(r));
  }
  if (!header) throw std::runtime_error(csv.string() + ": empty file (no header)");
  return rows;
}

std::string read_sequence_comment(const std::filesystem::path& csv, const std::string& key) {
  std::ifstream is(csv);
  if (!is) throw std::runtime_error(csv.string() + ": cannot open");
  for (std::string line; std::getline(is, line);) {
    const std::string t = trim_blanks(line);
    if (t.empty() || t[0] != '#') continue;
    const std::string body = trim_blanks(t.substr(1));
    if (body.size() > key.size() && body.compare(0, key.size(), key) == 0 && body[key.size()] == ':') {
      return trim_blanks(body.substr(key.size() + 1));
    }
  }
  return {};
}

std::filesystem::path write_sequence(const std::filesystem::path& dir, const std::vector<SequenceFrame>& frames,
                                     const std::vector<std::string>& comments) {
  std::filesystem::create_directories(dir);
  std::vector<SequenceRow> rows;
  rows.reserve(frames.size());
  char name[32];
  for (std::size_t i = 0; i < frames.size(); ++i) {
    std::snprintf(name, sizeof name, "frame_%04zu.png", i);
    const auto path = dir / name;
    if (!cv::imwrite(path.string(), frames[i].bgr)) {
      throw std::runtime_error(path.string() + ": cannot write image");
    }
    rows.push_back({name, frames[i].truth.encoder_angle_rad, frames[i].truth.sinkage_mm});
  }
  const auto csv = dir / "sequence.csv";
  write_sequence_csv(csv, rows, comments);
  return csv;
}

}  // namespace regolith::wheel_scene
