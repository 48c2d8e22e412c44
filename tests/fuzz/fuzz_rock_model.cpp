// libFuzzer target: the rock model file of the trained detector (`model:` of the sams component,
// `regolith rocks --method trained --model`, `regolith train rocks` output), read from its text by
// `parse_trained_model` (the same reader as `load_trained_model`, without the gzip layer). Only
// ModelError may leave it; a model that loads must score a candidate (features taken from the
// input's first bytes) to a number in [0, 1], its walk of the trees staying inside them (ASan),
// and a model with a pixel stage must map a small map and image to values in [0, 1].
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
  if (model.has_pixel_stage()) {
    // a 24 x 20 map and image from the input's bytes through the pixel stage: values in [0, 1]
    cv::Mat map(20, 24, CV_32F), intensity(20, 24, CV_8U);
    for (int i = 0; i < map.rows * map.cols; ++i) {
      const std::uint8_t b = data[static_cast<std::size_t>(i) % size];
      map.at<float>(i / map.cols, i % map.cols) = static_cast<float>(b) / 255.0f;
      intensity.at<std::uint8_t>(i / map.cols, i % map.cols) = static_cast<std::uint8_t>(b * 7u);
    }
    rs::TrainedMapScratch scratch;
    model.pixel_stage(intensity, map, scratch);
    for (int i = 0; i < map.rows * map.cols; ++i) {
      const float v = map.at<float>(i / map.cols, i % map.cols);
      if (!(v >= 0.0f && v <= 1.0f)) __builtin_trap();
    }
  }
  return 0;
}
