// The trained rock model's file (model_file.hpp): YAML through yaml-cpp, gzip through zlib.
#include "regolith/saliency/model_file.hpp"

#include <algorithm>
#include <bit>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <memory>
#include <string>
#include <type_traits>
#include <vector>

#include <zlib.h>

#include <yaml-cpp/yaml.h>

#include "trained_forest.hpp"

#ifndef REGOLITH_ROCKS_MODEL_SOURCE
#define REGOLITH_ROCKS_MODEL_SOURCE ""
#endif
#ifndef REGOLITH_ROCKS_MODEL_INSTALLED
#define REGOLITH_ROCKS_MODEL_INSTALLED ""
#endif

namespace regolith::saliency {
namespace {

constexpr std::size_t kMaxTrees = 100000;
constexpr std::size_t kMaxNodes = std::size_t{1} << 24;  // over all trees
// One node in `forest.nodes`: var, threshold, left, right (4 bytes each), value (8), little-endian.
constexpr std::size_t kNodeBytes = 24;

// Little-endian fields of a node record (whatever the host's byte order).
void put_le(std::string& out, std::uint64_t v, int bytes) {
  for (int k = 0; k < bytes; ++k) out.push_back(static_cast<char>((v >> (8 * k)) & 0xFFu));
}
// Only base64's alphabet, padding and white space: yaml-cpp 0.7's DecodeBase64 indexes its table
// with a plain (signed) char, so a byte >= 0x80 reads outside it (a SEGV the rock_model fuzz target
// found; jbeder/yaml-cpp issue 646); such text never reaches it.
bool is_base64_text(const std::string& s) {
  return std::all_of(s.begin(), s.end(), [](char c) {
    return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '+' || c == '/' ||
           c == '=' || c == ' ' || c == '\n' || c == '\r' || c == '\t';
  });
}
std::uint64_t get_le(const unsigned char* p, int bytes) {
  std::uint64_t v = 0;
  for (int k = 0; k < bytes; ++k) v |= std::uint64_t{p[k]} << (8 * k);
  return v;
}

template <class T>
const char* kind() {
  if constexpr (std::is_same_v<T, int>) return "an integer";
  if constexpr (std::is_same_v<T, double> || std::is_same_v<T, float>) return "a number";
  if constexpr (std::is_same_v<T, std::string>) return "a string";
  if constexpr (std::is_same_v<T, std::vector<int>>) return "a list of integers";
  if constexpr (std::is_same_v<T, std::vector<std::string>>) return "a list of strings";
  if constexpr (std::is_same_v<T, YAML::Binary>) return "base64 binary";
  return "a list of numbers";
}

// The typed fields of one map of the file; every error starts with the file's name and names the
// field by its path from the top ("candidates.min_area_px", "forest.trees[3].left") and its line.
class Fields {
 public:
  Fields(const YAML::Node& map, const std::string& file, std::string prefix)
      : map_(map), file_(file), prefix_(std::move(prefix)) {}

  template <class T>
  T get(const std::string& key) const {
    const YAML::Node n = node(key);
    try {
      return n.as<T>();
    } catch (const YAML::Exception&) {
      throw error(key, std::string("is not ") + kind<T>(), n);
    }
  }
  YAML::Node node(const std::string& key) const {
    const YAML::Node n = map_[key];
    if (!n.IsDefined() || n.IsNull()) throw ModelError(file_ + ": rock model: '" + prefix_ + key + "' is missing");
    return n;
  }
  Fields map(const std::string& key) const {
    const YAML::Node n = node(key);
    if (!n.IsMap()) throw error(key, "is not a map", n);
    return {n, file_, prefix_ + key + "."};
  }
  /// The maps of list `key` (1 to `max_count` of them).
  std::vector<Fields> maps(const std::string& key, std::size_t max_count) const {
    const YAML::Node n = node(key);
    if (!n.IsSequence() || n.size() == 0 || n.size() > max_count)
      throw error(key, "is not a list of 1 to " + std::to_string(max_count) + " maps", n);
    std::vector<Fields> out;
    for (std::size_t k = 0; k < n.size(); ++k) {
      const std::string item = key + "[" + std::to_string(k) + "]";
      if (!n[k].IsMap()) throw error(item, "is not a map", n[k]);
      out.emplace_back(n[k], file_, prefix_ + item + ".");
    }
    return out;
  }
  ModelError error(const std::string& key, const std::string& why, const YAML::Node& at) const {
    return ModelError(file_ + ": rock model: '" + prefix_ + key + "' " + why + " (line " +
                      std::to_string(at.Mark().line + 1) + ")");
  }
  ModelError error(const std::string& why) const { return ModelError(file_ + ": rock model: " + why); }
  const std::string& prefix() const { return prefix_; }

 private:
  YAML::Node map_;
  const std::string& file_;
  std::string prefix_;
};

// The one scalar `key` of the top-level map as text, "" when absent or not a scalar: the format
// and version are read leniently so that another file or version is named as such.
std::string scalar_text(const YAML::Node& root, const char* key) {
  const YAML::Node n = root[key];
  return n.IsDefined() && n.IsScalar() ? n.Scalar() : std::string();
}

void read_candidates(const Fields& c, CandidateParams& p) {
  p.coarse.sigma_px = c.get<double>("coarse_sigma_px");
  p.coarse.smooth_sigma_px = c.get<double>("coarse_smooth_px");
  p.fine.sigma_px = c.get<double>("fine_sigma_px");
  p.fine.smooth_sigma_px = c.get<double>("fine_smooth_px");
  p.coarse_scales = c.get<std::vector<double>>("coarse_scales");
  p.fine_scales = c.get<std::vector<double>>("fine_scales");
  p.chroma.sigma_px = c.get<double>("chroma_sigma_px");
  p.chroma.smooth_sigma_px = c.get<double>("chroma_smooth_px");
  p.chroma_scales = c.get<std::vector<double>>("chroma_scales");
  p.min_area = c.get<int>("min_area_px");
  p.open_radius = c.get<int>("open_radius_px");
  p.close_radius = c.get<int>("close_radius_px");
  p.working_width_px = c.get<int>("working_width_px");
  try {
    p.validate();
  } catch (const std::invalid_argument& e) {
    throw c.error(e.what());
  }
}

void read_box(const Fields& f, BoxParams& b) {
  b.score_threshold = f.get<double>("score_threshold");
  b.nms_iou = f.get<double>("nms_iou");
  b.refine_fraction = f.get<double>("box_refine_fraction");
  b.crowd.count = f.get<int>("crowd_count");
  b.crowd.threshold = f.get<double>("crowd_threshold");
  if (!(b.score_threshold >= 0.0 && b.score_threshold <= 1.0) || !(b.nms_iou > 0.0 && b.nms_iou <= 1.0))
    throw f.error("score_threshold / nms_iou out of range");
  if (!(b.refine_fraction >= 0.0 && b.refine_fraction < 1.0)) throw f.error("box_refine_fraction must be in [0, 1)");
  if (b.crowd.count < 0) throw f.error("crowd_count must be >= 0");
  if (!(b.crowd.threshold >= 0.0 && b.crowd.threshold <= 1.0)) throw f.error("crowd_threshold must be in [0, 1]");
}

// The trees of a forest map: `tree_sizes` (each tree's node count, in order) and `nodes` (their
// records back to back, kNodeBytes each, children tree-local), appended to one set of flat arrays
// (tree-local child indices become indices into them), then checked as a whole (Forest::check,
// whose errors name the tree).
void read_forest(const Fields& f, TrainedModel::Forest& forest) {
  const auto sizes = f.get<std::vector<int>>("tree_sizes");
  if (sizes.empty() || sizes.size() > kMaxTrees)
    throw f.error("tree_sizes", "is not a list of 1 to " + std::to_string(kMaxTrees) + " node counts",
                  f.node("tree_sizes"));
  std::size_t total = 0;
  for (int n : sizes) {
    if (n <= 0) throw f.error("tree_sizes", "holds a tree of " + std::to_string(n) + " nodes", f.node("tree_sizes"));
    total += static_cast<std::size_t>(n);
    if (total > kMaxNodes)
      throw f.error("tree_sizes", "holds more than " + std::to_string(kMaxNodes) + " nodes", f.node("tree_sizes"));
  }
  if (const YAML::Node text = f.node("nodes"); !text.IsScalar() || !is_base64_text(text.Scalar()))
    throw f.error("nodes", "is not base64 binary", text);
  const auto nodes = f.get<YAML::Binary>("nodes");
  if (nodes.size() != total * kNodeBytes)
    throw f.error("nodes",
                  "holds " + std::to_string(nodes.size()) + " bytes, tree_sizes' " + std::to_string(total) +
                      " nodes need " + std::to_string(total * kNodeBytes),
                  f.node("nodes"));
  forest.nodes.reserve(total);
  const unsigned char* p = nodes.data();
  for (int n : sizes) {
    const int offset = static_cast<int>(forest.nodes.size());
    forest.roots.push_back(offset);
    // an index outside the tree becomes one outside it after the offset too (check() names it)
    const auto shift = [&](std::int32_t i) { return i >= 0 && i < n ? i + offset : (i < 0 ? i : -2); };
    for (int i = 0; i < n; ++i, p += kNodeBytes) {
      const auto var = static_cast<std::int32_t>(get_le(p, 4));
      const auto threshold = std::bit_cast<float>(static_cast<std::uint32_t>(get_le(p + 4, 4)));
      const auto left = static_cast<std::int32_t>(get_le(p + 8, 4));
      const auto right = static_cast<std::int32_t>(get_le(p + 12, 4));
      const auto value = std::bit_cast<double>(get_le(p + 16, 8));
      forest.nodes.push_back({var, threshold, shift(left), shift(right), value});
    }
  }
  forest.check();
  forest.build_walk();
}

// read_forest() into a new forest of `feature_count` features, its shape errors as ModelError.
std::shared_ptr<TrainedModel::Forest> read_checked_forest(const Fields& f, int feature_count, const std::string& name) {
  auto forest = std::make_shared<TrainedModel::Forest>(feature_count);
  try {
    read_forest(f, *forest);
  } catch (const ModelError&) {
    throw;
  } catch (const std::runtime_error& e) {  // Forest::check
    throw ModelError(name + ": " + e.what());
  }
  return forest;
}

TrainedModel read_model(const YAML::Node& root, const std::string& name) {
  const std::string format = scalar_text(root, "format");
  if (format != kTrainedModelFormat)
    throw ModelError(name + ": not a regolith rock model (format '" + format + "', expected '" + kTrainedModelFormat +
                     "')");
  const std::string version = scalar_text(root, "version");
  if (version != std::to_string(kTrainedModelVersion))
    throw ModelError(name + ": rock model version " + (version.empty() ? "(none)" : version) +
                     ", this build reads version " + std::to_string(kTrainedModelVersion) +
                     " (re-train with `regolith train rocks`)");
  const Fields top(root, name, "");
  if (top.get<int>("feature_count") != kFeatureCount)
    throw top.error("it has " + std::to_string(top.get<int>("feature_count")) + " features, this build computes " +
                    std::to_string(kFeatureCount));
  const auto features = top.get<std::vector<std::string>>("features");
  if (features != feature_names()) throw top.error("its feature names differ from this build's");
  TrainedModel m;
  read_candidates(top.map("candidates"), m.candidates);
  read_box(top, m.box);
  m.training_images = top.get<int>("training_images");
  m.training_samples = top.get<int>("training_samples");
  m.training_positives = top.get<int>("training_positives");
  m.forest_ = read_checked_forest(top.map("forest"), kFeatureCount, name);
  // the pixel stage: a map, or `none` for a model trained without one
  if (top.node("pixel_stage").IsScalar() && top.get<std::string>("pixel_stage") == "none") return m;
  const Fields px = top.map("pixel_stage");
  if (px.get<int>("grid_divisor") != kPixelGridDivisor)
    throw px.error("its pixel stage's grid_divisor is " + std::to_string(px.get<int>("grid_divisor")) +
                   ", this build's is " + std::to_string(kPixelGridDivisor));
  if (px.get<int>("feature_count") != kPixelFeatureCount)
    throw px.error("its pixel stage has " + std::to_string(px.get<int>("feature_count")) +
                   " features, this build computes " + std::to_string(kPixelFeatureCount));
  if (px.get<std::vector<std::string>>("features") != pixel_feature_names())
    throw px.error("its pixel stage's feature names differ from this build's");
  m.pixel_forest_ = read_checked_forest(px.map("forest"), kPixelFeatureCount, name);
  return m;
}

// The model file's bytes, gzip-decompressed when they are gzip (zlib's reader passes other files
// through), at most kMaxModelFileBytes.
std::string read_model_text(const std::string& path) {
  gzFile f = gzopen(path.c_str(), "rb");
  if (f == nullptr) throw ModelError(path + ": cannot read rock model file");
  std::string text;
  std::vector<char> buf(1 << 16);
  int n = 0;
  while ((n = gzread(f, buf.data(), static_cast<unsigned>(buf.size()))) > 0) {
    text.append(buf.data(), static_cast<std::size_t>(n));
    if (text.size() > kMaxModelFileBytes) {
      gzclose(f);
      throw ModelError(path + ": rock model file larger than " + std::to_string(kMaxModelFileBytes >> 20) +
                       " MiB once decompressed");
    }
  }
  int err = Z_OK;
  const std::string why = n < 0 ? gzerror(f, &err) : "";
  gzclose(f);
  if (n < 0) throw ModelError(path + ": corrupt rock model file (" + why + ")");
  return text;
}

// `text` into `path` through zlib's writer: gzip-compressed (level 9; zlib writes no time stamp,
// so the same text gives the same bytes) when `gzip`, else as it is (zlib's transparent mode).
// False on any error.
bool write_model_bytes(const std::string& path, const std::string& text, bool gzip) {
  gzFile f = gzopen(path.c_str(), gzip ? "wb9" : "wbT");
  if (f == nullptr) return false;
  bool ok = true;
  for (std::size_t at = 0; ok && at < text.size();) {
    const unsigned chunk = static_cast<unsigned>(std::min<std::size_t>(text.size() - at, 1 << 20));
    ok = gzwrite(f, text.data() + at, chunk) == static_cast<int>(chunk);
    at += chunk;
  }
  return gzclose(f) == Z_OK && ok;
}

// `forest` as a map {tree_sizes: [...], nodes: !!binary}, children tree-local (read_forest()).
void emit_forest(YAML::Emitter& e, const TrainedModel::Forest& forest) {
  std::vector<int> sizes;
  std::string bytes;
  bytes.reserve(forest.nodes.size() * kNodeBytes);
  for (std::size_t k = 0; k < forest.roots.size(); ++k) {
    const int begin = forest.roots[k];
    const int end = k + 1 < forest.roots.size() ? forest.roots[k + 1] : static_cast<int>(forest.nodes.size());
    sizes.push_back(end - begin);
    for (int i = begin; i < end; ++i) {
      const TrainedModel::Forest::Node& n = forest.nodes[static_cast<std::size_t>(i)];
      put_le(bytes, static_cast<std::uint32_t>(n.var), 4);
      put_le(bytes, std::bit_cast<std::uint32_t>(n.threshold), 4);
      put_le(bytes, static_cast<std::uint32_t>(n.left < 0 ? -1 : n.left - begin), 4);
      put_le(bytes, static_cast<std::uint32_t>(n.right < 0 ? -1 : n.right - begin), 4);
      put_le(bytes, std::bit_cast<std::uint64_t>(n.value), 8);
    }
  }
  e << YAML::BeginMap;
  e << YAML::Key << "tree_sizes" << YAML::Value << YAML::Flow << sizes;
  e << YAML::Key << "nodes" << YAML::Value
    << YAML::Binary(reinterpret_cast<const unsigned char*>(bytes.data()), bytes.size());
  e << YAML::EndMap;
}

}  // namespace

TrainedModel parse_trained_model(const std::string& text, const std::string& name) {
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw ModelError(name + ": corrupt rock model file (" + e.what() + ")");
  }
  if (!root.IsMap()) throw ModelError(name + ": corrupt rock model file (its top level is not a YAML map)");
  try {
    return read_model(root, name);
  } catch (const YAML::Exception& e) {  // anything the typed reads above did not name
    throw ModelError(name + ": corrupt rock model file (" + e.what() + ")");
  }
}

TrainedModel load_trained_model(const std::string& path) {
  if (!std::filesystem::is_regular_file(path)) throw ModelError(path + ": rock model file not found");
  return parse_trained_model(read_model_text(path), path);
}

std::string trained_model_text(const TrainedModel& model) {
  if (!model.trained()) throw std::invalid_argument("trained_model_text: the model has no forest");
  YAML::Emitter e;
  e.SetIndent(2);
  // enough digits that every float / double reads back as itself
  e.SetFloatPrecision(std::numeric_limits<float>::max_digits10);
  e.SetDoublePrecision(std::numeric_limits<double>::max_digits10);
  e << YAML::Comment("regolith trained rock model (`regolith train rocks`); format: regolith/saliency/model_file.hpp");
  e << YAML::BeginMap;
  e << YAML::Key << "format" << YAML::Value << kTrainedModelFormat;
  e << YAML::Key << "version" << YAML::Value << kTrainedModelVersion;
  e << YAML::Key << "feature_count" << YAML::Value << kFeatureCount;
  e << YAML::Key << "features" << YAML::Value << YAML::Flow << feature_names();
  const CandidateParams& c = model.candidates;
  e << YAML::Key << "candidates" << YAML::Value << YAML::BeginMap;
  e << YAML::Key << "coarse_sigma_px" << YAML::Value << c.coarse.sigma_px;
  e << YAML::Key << "coarse_smooth_px" << YAML::Value << c.coarse.smooth_sigma_px;
  e << YAML::Key << "fine_sigma_px" << YAML::Value << c.fine.sigma_px;
  e << YAML::Key << "fine_smooth_px" << YAML::Value << c.fine.smooth_sigma_px;
  e << YAML::Key << "coarse_scales" << YAML::Value << YAML::Flow << c.coarse_scales;
  e << YAML::Key << "fine_scales" << YAML::Value << YAML::Flow << c.fine_scales;
  e << YAML::Key << "chroma_sigma_px" << YAML::Value << c.chroma.sigma_px;
  e << YAML::Key << "chroma_smooth_px" << YAML::Value << c.chroma.smooth_sigma_px;
  e << YAML::Key << "chroma_scales" << YAML::Value << YAML::Flow << c.chroma_scales;
  e << YAML::Key << "min_area_px" << YAML::Value << c.min_area;
  e << YAML::Key << "open_radius_px" << YAML::Value << c.open_radius;
  e << YAML::Key << "close_radius_px" << YAML::Value << c.close_radius;
  e << YAML::Key << "working_width_px" << YAML::Value << c.working_width_px;
  e << YAML::EndMap;
  const BoxParams& b = model.box;
  e << YAML::Key << "score_threshold" << YAML::Value << b.score_threshold;
  e << YAML::Key << "nms_iou" << YAML::Value << b.nms_iou;
  e << YAML::Key << "box_refine_fraction" << YAML::Value << b.refine_fraction;
  e << YAML::Key << "crowd_count" << YAML::Value << b.crowd.count;
  e << YAML::Key << "crowd_threshold" << YAML::Value << b.crowd.threshold;
  e << YAML::Key << "training_images" << YAML::Value << model.training_images;
  e << YAML::Key << "training_samples" << YAML::Value << model.training_samples;
  e << YAML::Key << "training_positives" << YAML::Value << model.training_positives;
  e << YAML::Key << "forest" << YAML::Value;
  emit_forest(e, *model.forest_);
  e << YAML::Key << "pixel_stage" << YAML::Value;
  if (!model.has_pixel_stage()) {
    e << "none";
  } else {
    e << YAML::BeginMap;
    e << YAML::Key << "grid_divisor" << YAML::Value << kPixelGridDivisor;
    e << YAML::Key << "feature_count" << YAML::Value << kPixelFeatureCount;
    e << YAML::Key << "features" << YAML::Value << YAML::Flow << pixel_feature_names();
    e << YAML::Key << "forest" << YAML::Value;
    emit_forest(e, *model.pixel_forest_);
    e << YAML::EndMap;
  }
  e << YAML::EndMap;
  if (!e.good()) throw std::logic_error("trained_model_text: " + e.GetLastError());
  return std::string(e.c_str()) + "\n";
}

void save_trained_model(const TrainedModel& model, const std::string& path) {
  if (!model.trained()) throw ModelError(path + ": cannot save an untrained model");
  const std::string text = trained_model_text(model);
  // through a temporary beside it: a failed write leaves an existing model file as it was
  const std::string tmp = path + ".part";
  if (!write_model_bytes(tmp, text, path.ends_with(".gz"))) {
    std::error_code ec;
    std::filesystem::remove(tmp, ec);
    throw ModelError(path + ": cannot write the rock model file");
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::filesystem::remove(tmp, ec);
    throw ModelError(path + ": cannot write the rock model file (" + ec.message() + ")");
  }
}

std::string default_trained_model_path() {
  const std::string src = REGOLITH_ROCKS_MODEL_SOURCE;
  if (!src.empty() && std::filesystem::is_regular_file(src)) return src;
  const std::string inst = REGOLITH_ROCKS_MODEL_INSTALLED;
  if (!inst.empty()) return inst;
  return src;
}

}  // namespace regolith::saliency
