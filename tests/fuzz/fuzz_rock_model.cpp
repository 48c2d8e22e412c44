// libFuzzer target: the rock model file of the trained detector (`model:` of the sams component,
// `regolith rocks --method trained --model`, `regolith train rocks` output), read from its text by
// `parse_trained_model` (the same reader as `load_trained_model`, without the gzip layer). Only
// ModelError may leave it; a model that loads must score a candidate (features taken from the
// input's first bytes) to a number in [0, 1], its walk of the trees staying inside them (ASan).
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "regolith/saliency/model_file.hpp"
#include "regolith/saliency/trained.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  namespace rs = regolith::saliency;
  rs::TrainedModel model;
  try {
    model = rs::parse_trained_model(std::string(reinterpret_cast<const char*>(data), size), "fuzz.yml");
  } catch (const rs::ModelError&) {
    return 0;  // refused with a message naming the file
  }
  rs::CandidateSet set;
  set.size = cv::Size(64, 64);
  rs::RockCandidate c;
  c.box = cv::Rect(8, 8, 16, 16);
  for (std::size_t k = 0; k < c.features.size(); ++k)
    c.features[k] = k < size ? static_cast<float>(data[k]) / 32.0f - 4.0f : 0.0f;
  set.candidates.push_back(c);
  std::vector<float> scores;
  model.score(set, scores);
  if (scores.size() != 1 || !(scores[0] >= 0.0f && scores[0] <= 1.0f)) __builtin_trap();
  return 0;
}
