#pragma once
// Internal to regolith::saliency: the trained model's forest, shared by the model
// (trained_model.cpp: scoring, files) and its training (train_rocks.cpp).
#include <stdexcept>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/ml.hpp>

#include "regolith/saliency/trained.hpp"

namespace regolith::saliency {

struct TrainedModel::Forest {
  cv::Ptr<cv::ml::RTrees> rtrees;
  // The trees again, flat, for an allocation-free evaluation (cv::ml::StatModel::predict makes
  // matrices at every call). Leaves have var < 0.
  struct Node {
    int var = -1;
    float threshold = 0.0f;
    int left = -1, right = -1;
    double value = 0.0;
  };
  std::vector<Node> nodes;
  std::vector<int> roots;

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
      const auto& sp = splits.at(static_cast<std::size_t>(n.split));
      // every feature is an ordered variable (fit_forest's var_type): no categorical subsets
      o.var = sp.varIdx;
      o.threshold = sp.c;
      // value <= c goes left; an inversed split swaps the children
      o.left = sp.inversed ? n.right : n.left;
      o.right = sp.inversed ? n.left : n.right;
      if (o.var < 0 || o.var >= kFeatureCount || o.left < 0 || o.right < 0 ||
          static_cast<std::size_t>(o.left) >= src.size() || static_cast<std::size_t>(o.right) >= src.size())
        throw std::runtime_error("rock model: a tree node points outside the forest");
    }
    roots = rtrees->getRoots();
    for (int r : roots)
      if (r < 0 || static_cast<std::size_t>(r) >= nodes.size()) throw std::runtime_error("rock model: bad tree root");
  }

  float predict(const float* x) const {
    double sum = 0.0;
    for (int r : roots) {
      int k = r;
      // depth <= max_depth (<= 30): the bound only stops a malformed file's cycle
      for (int step = 0; nodes[static_cast<std::size_t>(k)].var >= 0 && step < 64; ++step) {
        const Node& n = nodes[static_cast<std::size_t>(k)];
        k = x[n.var] <= n.threshold ? n.left : n.right;
      }
      sum += nodes[static_cast<std::size_t>(k)].value;
    }
    return roots.empty() ? 0.0f : static_cast<float>(sum / static_cast<double>(roots.size()));
  }
};

/// One row of kFeatureCount features per candidate (CV_32F): what cv::ml::RTrees reads.
cv::Mat feature_matrix(const std::vector<RockCandidate>& cands);

}  // namespace regolith::saliency
