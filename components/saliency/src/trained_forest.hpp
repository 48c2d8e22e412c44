#pragma once
// Internal to regolith::saliency: the trained model's forest, shared by the model
// (trained_model.cpp: scoring), its training (train_rocks.cpp) and its file (model_file.cpp).
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/ml.hpp>

#include "regolith/saliency/trained.hpp"

namespace regolith::saliency {

/// The forest as flat arrays, for an allocation-free evaluation (cv::ml::StatModel::predict makes
/// matrices at every call) and for the model file. Tree k is the nodes [roots[k], roots[k+1])
/// (the last runs to the end), its root first; every split's children lie after it in its own
/// tree, so a walk from a root always ends at a leaf.
struct TrainedModel::Forest {
  /// The forest OpenCV trained: only in a freshly trained model (score_by_opencv); null in a
  /// model read from its file.
  cv::Ptr<cv::ml::RTrees> rtrees;
  struct Node {
    int var = -1;               ///< the feature a split tests; -1 at a leaf
    float threshold = 0.0f;     ///< x[var] <= threshold goes left
    int left = -1, right = -1;  ///< indices into nodes; -1 at a leaf
    double value = 0.0;         ///< the node's mean label (the output at a leaf)
  };
  std::vector<Node> nodes;
  std::vector<int> roots;
  /// How many features a split may test: kFeatureCount for the box forest, kPixelFeatureCount for
  /// the pixel stage's.
  int feature_count = kFeatureCount;

  Forest() = default;
  explicit Forest(int features) : feature_count(features) {}

  /// nodes / roots from rtrees; throws std::runtime_error when check() fails.
  void flatten() {
    nodes.clear();
    roots.clear();
    const auto& src = rtrees->getNodes();
    const auto& splits = rtrees->getSplits();
    nodes.resize(src.size());
    for (std::size_t i = 0; i < src.size(); ++i) {
      const auto& n = src[i];
      Node& o = nodes[i];
      o.value = n.value;
      if (n.split < 0) continue;
      if (n.split >= static_cast<int>(splits.size())) throw std::runtime_error("rock model: a node's split is missing");
      const auto& sp = splits[static_cast<std::size_t>(n.split)];
      // every feature is an ordered variable (fit_forest's var_type): no categorical subsets
      o.var = sp.varIdx;
      o.threshold = sp.c;
      // value <= c goes left; an inversed split swaps the children
      o.left = sp.inversed ? n.right : n.left;
      o.right = sp.inversed ? n.left : n.right;
    }
    roots = rtrees->getRoots();
    check();
    build_walk();
  }

  /// Throws std::runtime_error naming the tree and node when the arrays are not a forest of
  /// feature_count features as described above (a walk could leave the arrays or never end).
  void check() const {
    if (roots.empty()) throw std::runtime_error("rock model: the forest has no trees");
    if (roots.front() != 0) throw std::runtime_error("rock model: the first tree does not start at node 0");
    for (std::size_t k = 0; k < roots.size(); ++k) {
      const long begin = roots[k];
      const long end = k + 1 < roots.size() ? roots[k + 1] : static_cast<long>(nodes.size());
      const auto bad = [&](long i, const std::string& why) {
        return std::runtime_error("rock model: tree " + std::to_string(k) + " node " + std::to_string(i - begin) +
                                  ": " + why);
      };
      if (end <= begin || end > static_cast<long>(nodes.size()))
        throw std::runtime_error("rock model: tree " + std::to_string(k) + " has no nodes");
      for (long i = begin; i < end; ++i) {
        const Node& n = nodes[static_cast<std::size_t>(i)];
        if (!std::isfinite(n.value)) throw bad(i, "value is not finite");
        if (n.var == -1) {
          if (n.left != -1 || n.right != -1) throw bad(i, "a leaf (var -1) with children");
          continue;
        }
        if (n.var < 0 || n.var >= feature_count)
          throw bad(i, "var " + std::to_string(n.var) + " is not a feature (0-" + std::to_string(feature_count - 1) +
                           ", or -1 at a leaf)");
        if (!std::isfinite(n.threshold)) throw bad(i, "threshold is not finite");
        if (n.left <= i || n.left >= end || n.right <= i || n.right >= end)
          throw bad(i, "a child outside the nodes after it in its tree");
      }
    }
  }

  /// The trees for predict_rows(): per node its feature, threshold and children (a leaf's both
  /// itself, so a walk of the tree's depth ends on its leaf whatever the depth of that leaf), and
  /// each tree's depth. Made by build_walk() after check().
  struct Step {
    int var = 0;
    float threshold = 0.0f;
    int child[2] = {0, 0};  ///< [0]: x[var] <= threshold; [1]: otherwise (NaN included)
  };
  std::vector<Step> steps;
  std::vector<int> depths;

  /// steps / depths from nodes / roots (which check() has accepted).
  void build_walk() {
    steps.assign(nodes.size(), Step{});
    depths.assign(roots.size(), 0);
    std::vector<int> depth(nodes.size(), 0);
    for (std::size_t k = 0; k < roots.size(); ++k) {
      const int begin = roots[k];
      const int end = k + 1 < roots.size() ? roots[k + 1] : static_cast<int>(nodes.size());
      for (int i = begin; i < end; ++i) {
        const Node& n = nodes[static_cast<std::size_t>(i)];
        Step& s = steps[static_cast<std::size_t>(i)];
        if (n.var < 0) {
          s.child[0] = s.child[1] = i;
          continue;
        }
        s = Step{n.var, n.threshold, {n.left, n.right}};
        // children lie after their node (check()), so a node's depth is known before theirs
        const int d = depth[static_cast<std::size_t>(i)] + 1;
        depth[static_cast<std::size_t>(n.left)] = depth[static_cast<std::size_t>(n.right)] = d;
        depths[k] = std::max(depths[k], d);
      }
    }
  }

  /// predict() of every row of `x` (CV_32F, feature_count columns) into `out` (x.rows values),
  /// tree by tree over all rows, eight rows walked side by side (independent chains of loads the
  /// processor overlaps), each for the tree's depth; the sums in `sums` (x.rows doubles, scratch):
  /// the same values as predict() row by row.
  void predict_rows(const cv::Mat& x, double* sums, float* out) const {
    const int n = x.rows;
    std::fill(sums, sums + n, 0.0);
    constexpr int kLanes = 8;
    for (std::size_t t = 0; t < roots.size(); ++t) {
      const int root = roots[t], depth = depths[t];  // the 8 lanes: leaf()'s walk, interleaved
      int i = 0;
      for (; i + kLanes <= n; i += kLanes) {
        int k[kLanes];
        const float* xs[kLanes];
        for (int j = 0; j < kLanes; ++j) k[j] = root, xs[j] = x.ptr<float>(i + j);
        for (int d = 0; d < depth; ++d)
          for (int j = 0; j < kLanes; ++j) k[j] = next(k[j], xs[j]);
        for (int j = 0; j < kLanes; ++j) sums[i + j] += nodes[static_cast<std::size_t>(k[j])].value;
      }
      for (; i < n; ++i) sums[i] += nodes[static_cast<std::size_t>(leaf(t, x.ptr<float>(i)))].value;
    }
    const double count = static_cast<double>(std::max<std::size_t>(roots.size(), 1));
    for (int i = 0; i < n; ++i) out[i] = static_cast<float>(sums[i] / count);
  }

  /// One step of a walk from node `k`: x[var] <= threshold goes left, anything else (NaN
  /// included) right; a leaf stays where it is.
  int next(int k, const float* x) const {
    const Step& s = steps[static_cast<std::size_t>(k)];
    return s.child[!(x[s.var] <= s.threshold)];
  }
  /// The leaf of tree `t` that `x` reaches: depths[t] steps from its root.
  int leaf(std::size_t t, const float* x) const {
    int k = roots[t];
    for (int d = 0; d < depths[t]; ++d) k = next(k, x);
    return k;
  }

  float predict(const float* x) const {
    double sum = 0.0;
    for (std::size_t t = 0; t < roots.size(); ++t) sum += nodes[static_cast<std::size_t>(leaf(t, x))].value;
    return roots.empty() ? 0.0f : static_cast<float>(sum / static_cast<double>(roots.size()));
  }
};

/// One row of kFeatureCount features per candidate (CV_32F): what cv::ml::RTrees reads.
cv::Mat feature_matrix(const std::vector<RockCandidate>& cands);

}  // namespace regolith::saliency
