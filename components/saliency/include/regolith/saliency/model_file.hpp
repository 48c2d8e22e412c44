#pragma once
// The trained rock model's file (library regolith::saliency_model_file): YAML read and written
// with yaml-cpp, gzip-compressed when the name ends in .gz. It holds a format name and version,
// the candidate parameters, the box rule (BoxParams), the training counts and the forest, its
// nodes as one list of fixed-size binary records (YAML's !!binary, base64):
//
//   forest:
//     tree_sizes: [449, 503, ...]     # each tree's node count, in order
//     nodes: !!binary "JQAAAN..."     # the trees' nodes back to back, 24 bytes each, little-endian:
//                                     #   var (int32): the feature the node's split tests; -1 at a leaf
//                                     #   threshold (float32): x[var] <= threshold goes to `left`
//                                     #   left, right (int32): node indices within the tree, after
//                                     #     the node; -1 at a leaf
//                                     #   value (float64): the node's mean label; a leaf's is its output
//   pixel_stage:                      # pixel_stage.hpp; `pixel_stage: none` for a model without
//     grid_divisor: 4
//     feature_count: 13
//     features: [map, map_blur1, ...]
//     forest: {tree_sizes: [...], nodes: !!binary ...}  # as above, over the pixel features
//
// The forests are binary because yaml-cpp reads ~250 k numbers a second: the shipped model's
// ~150 k took 0.6 s to load as text, its two binary lists take ~0.08 s. Every number reads back
// as itself (the records hold the float / double bits; the rest is written with enough digits),
// so a model scores the same after a save and a load, and re-training the same images writes the
// same text.
// Reading checks everything it reads (types, ranges, the trees' shape): a missing, corrupt,
// other-format or other-version file throws ModelError naming the file and the field; nothing in
// a file can make the reader or the model's walk of its trees crash or loop (fuzz target
// rock_model). The algorithm library (regolith::saliency) takes no yaml-cpp; its callers that
// read or write models (the `sams` component, the CLI, the tests) link this one.
#include <stdexcept>
#include <string>

#include "regolith/core/text_file.hpp"
#include "regolith/saliency/trained.hpp"

namespace regolith::saliency {

/// A model file problem (missing, unreadable, corrupt, other format or version, cannot write).
/// The message starts with the file's name.
class ModelError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The model in file `path` (gzip or plain YAML, at most kMaxModelFileBytes once decompressed).
TrainedModel load_trained_model(const std::string& path);
/// The same from the text of a plain YAML model file; errors start with `name`.
TrainedModel parse_trained_model(const std::string& text, const std::string& name);
/// The model's YAML text (what save_trained_model writes, before compression).
std::string trained_model_text(const TrainedModel& model);
/// Writes `model` to `path` (gzip when it ends in .gz) through a temporary file beside it, so a
/// failed save leaves an existing file as it was. Throws ModelError naming the file.
void save_trained_model(const TrainedModel& model, const std::string& path);

/// The bound of every text file from outside (regolith/core/text_file.hpp, 16 MiB): yaml-cpp
/// holds up to ~50 bytes per byte of number-dense text while it reads (version 6 of the shipped
/// model, 1.25 MB of numbers, peaked at 85 MB resident; version 7's binary lists take ~5 MB), so a
/// load stays under ~1 GB.
inline constexpr std::size_t kMaxModelFileBytes = kMaxTextFileBytes;

/// The shipped model: the source-tree file when it exists, else the installed one.
std::string default_trained_model_path();

}  // namespace regolith::saliency
