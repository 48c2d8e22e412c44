// Per-frame saliency + post-processing time at the MarsData image size (560 x
// 500) and at 640 x 480: SAMS (structure channel from a precomputed / shared
// DTM, and including its own SfS), Itti, the intensity contrast |I - G*I|
// (default parameters and post-processing), OpenCV spectral residual and
// fine-grained, and the trained ranking detector (issue 15: candidates + features + the shipped
// forest + selection). Prints each time as a ratio against Itti measured in the same run, and the
// trained detector's against SAMS and the contrast peer. Single thread (cv::setNumThreads(1)).
#include <cstdio>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "regolith/saliency/contrast.hpp"
#include "regolith/saliency/detect.hpp"
#include "regolith/saliency/image_ops.hpp"
#include "regolith/saliency/itti.hpp"
#include "regolith/saliency/model_file.hpp"
#include "regolith/saliency/peers.hpp"
#include "regolith/saliency/trained.hpp"
#ifdef REGOLITH_HAVE_SFS  // bench/saliency/CMakeLists.txt, when regolith::sfs is built
#include "regolith/saliency/sfs_height.hpp"
#endif

namespace rs = regolith::saliency;

namespace {

cv::Mat frame(cv::Size size) {
  const std::string p =
      std::string(REGOLITH_SHARED_DIR) + "/data/marsdata_rocks_dev/images/1044_1044MR0045730490204497E01_DXXX.jpg";
  cv::Mat img = cv::imread(p);
  if (img.empty()) {  // shared data absent: a synthetic textured frame with
                      // bright blobs
    img.create(size, CV_8UC3);
    cv::randu(img, cv::Scalar::all(60), cv::Scalar::all(160));
    cv::GaussianBlur(img, img, cv::Size(0, 0), 2.0);
    for (int k = 0; k < 12; ++k) {
      cv::circle(img, {40 + 45 * k, 100 + 25 * (k % 5)}, 10 + k, cv::Scalar(220, 220, 230), -1);
    }
  }
  if (img.size() != size) cv::resize(img, img, size, 0, 0, cv::INTER_AREA);
  return img;
}

void record(benchmark::State& st) {
  st.counters["fps"] = benchmark::Counter(static_cast<double>(st.iterations()), benchmark::Counter::kIsRate);
}

cv::Size size_of(int arg) {
  return arg == 0 ? cv::Size(560, 500) : cv::Size(640, 480);
}

void BM_Itti(benchmark::State& st) {
  cv::setNumThreads(1);
  const cv::Mat img = frame(size_of(static_cast<int>(st.range(0))));
  rs::IttiSaliency itti;
  rs::BoxDetector det;
  cv::Mat sal;
  std::vector<rs::Detection> out;
  for (auto _ : st) {
    itti.compute(img, sal);
    det.detect(sal, out);
    benchmark::DoNotOptimize(out.data());
  }
  record(st);
}

void BM_SamsSharedDtm(benchmark::State& st) {
  cv::setNumThreads(1);
  const cv::Mat img = frame(size_of(static_cast<int>(st.range(0))));
  // A DTM computed elsewhere (shared with the terrain map): here a smooth
  // synthetic relief.
  cv::Mat height(img.size(), CV_32F);
  cv::randu(height, 0.0, 1.0);
  cv::GaussianBlur(height, height, cv::Size(0, 0), 6.0);
  rs::IttiParams p;
  p.weights.structure = 0.4;
  rs::IttiSaliency sams(p);
  rs::BoxDetector det;
  cv::Mat sal;
  std::vector<rs::Detection> out;
  for (auto _ : st) {
    sams.compute(img, height, sal);
    det.detect(sal, out);
    benchmark::DoNotOptimize(out.data());
  }
  record(st);
}

#ifdef REGOLITH_HAVE_SFS
void BM_SamsWithSfs(benchmark::State& st) {
  cv::setNumThreads(1);
  const cv::Mat img = frame(size_of(static_cast<int>(st.range(0))));
  rs::IttiParams p;
  p.weights.structure = 0.4;
  rs::IttiSaliency sams(p);
  rs::SfsHeight sfs;
  rs::BoxDetector det;
  cv::Mat sal, h;
  std::vector<rs::Detection> out;
  for (auto _ : st) {
    sfs(img, h);
    sams.compute(img, h, sal);
    det.detect(sal, out);
    benchmark::DoNotOptimize(out.data());
  }
  record(st);
}
BENCHMARK(BM_SamsWithSfs)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);
#endif

void BM_Contrast(benchmark::State& st) {
  cv::setNumThreads(1);
  const cv::Mat img = frame(size_of(static_cast<int>(st.range(0))));
  rs::ContrastSaliency contrast;
  rs::BoxDetector det(rs::contrast_post_processing());
  cv::Mat sal;
  std::vector<rs::Detection> out;
  for (auto _ : st) {
    contrast.compute(img, sal);
    det.detect(sal, out);
    benchmark::DoNotOptimize(out.data());
  }
  record(st);
}

void peer(benchmark::State& st, rs::Method m) {
  cv::setNumThreads(1);
  const cv::Mat img = frame(size_of(static_cast<int>(st.range(0))));
  rs::OpenCvSaliency s(m);
  rs::BoxDetector det;
  cv::Mat sal;
  std::vector<rs::Detection> out;
  for (auto _ : st) {
    s.compute(img, sal);
    det.detect(sal, out);
    benchmark::DoNotOptimize(out.data());
  }
  record(st);
}
void BM_SpectralResidual(benchmark::State& st) {
  peer(st, rs::Method::kSpectralResidual);
}
void BM_FineGrained(benchmark::State& st) {
  peer(st, rs::Method::kFineGrained);
}

void trained(benchmark::State& st, bool grey) {
  cv::setNumThreads(1);
  cv::Mat img = frame(size_of(static_cast<int>(st.range(0))));
  if (grey) cv::cvtColor(img, img, cv::COLOR_BGR2GRAY);
  const rs::TrainedModel model = rs::load_trained_model(rs::default_trained_model_path());
  rs::CandidateExtractor extractor(model.candidates);
  rs::CandidateSet set;
  for (auto _ : st) {
    extractor.extract(img, set);
    const std::vector<rs::Detection> out = rs::TrainedModel::select(set, model.score(set), model.box);
    benchmark::DoNotOptimize(out.data());
  }
  record(st);
}
// The colour Mastcam frame (`regolith rocks`), and the same frame grey: what the sams component
// gives the detector (the DTM's image; no chroma map to compute).
void BM_Trained(benchmark::State& st) {
  trained(st, false);
}
void BM_TrainedGrey(benchmark::State& st) {
  trained(st, true);
}

// The pixel score map the sams component publishes as its saliency layer with method trained
// (each candidate's blobs filled and painted with its score), from one extracted and scored frame
// (/0, /1: the two sizes); /2, /3 the same plus the box refinement on it; /4, /5 plus the guided
// filter after it; /6, /7 plus the pixel stage (the map the component publishes).
void BM_TrainedScoreMap(benchmark::State& st) {
  const bool refine = st.range(0) >= 2, guided = st.range(0) >= 4, pixel = st.range(0) >= 6;
  cv::setNumThreads(1);
  const cv::Mat img = frame(size_of(static_cast<int>(st.range(0) % 2)));
  const rs::TrainedModel model = rs::load_trained_model(rs::default_trained_model_path());
  rs::CandidateExtractor extractor(model.candidates);
  rs::CandidateSet set;
  extractor.extract(img, set);
  const std::vector<float> scores = model.score(set);
  const std::vector<rs::Detection> kept = rs::TrainedModel::select(set, scores, model.box);
  std::vector<rs::Detection> dets = kept;
  cv::Mat map;
  std::vector<int> spans;
  rs::TrainedModel::BoxScratch scratch;
  rs::TrainedMapScratch map_scratch;
  cv::Mat grey;
  cv::cvtColor(img, grey, cv::COLOR_BGR2GRAY);
  for (auto _ : st) {
    rs::TrainedModel::score_map(set, scores, map, spans);
    if (refine) {
      std::copy(kept.begin(), kept.end(), dets.begin());
      rs::TrainedModel::refine(map, model.box.refine_fraction, dets, scratch);
    }
    if (guided) model.guide_map(grey, map, map_scratch);
    if (pixel) model.pixel_stage(grey, map, map_scratch);
    benchmark::DoNotOptimize(map.data);
  }
  st.counters["candidates"] = static_cast<double>(set.candidates.size());
}
BENCHMARK(BM_TrainedScoreMap)->DenseRange(0, 7)->Unit(benchmark::kMillisecond);

// The trained map's guided filter alone at 560x500 (radius 12 px): /20 GuidedFilter, /21 the same
// formula written with cv::boxFilter (normalised, BORDER_REFLECT_101 instead of clipped windows),
// the usual OpenCV way; its ratio is printed at the end.
void BM_GuidedFilter(benchmark::State& st) {
  cv::setNumThreads(1);
  cv::Mat grey, guide, map(500, 560, CV_32F);
  cv::cvtColor(frame({560, 500}), grey, cv::COLOR_BGR2GRAY);
  grey.convertTo(guide, CV_32F, 1.0 / 255.0);
  cv::randu(map, 0.0, 1.0);
  const int r = rs::TrainedModel::kMapGuideRadiusPx;
  const double eps = rs::TrainedModel::kMapGuideEps;
  rs::GuidedFilter ours(r, eps);
  cv::Mat out, mi, mp, mip, mii, a, b, ma, mb;
  const cv::Size k(2 * r + 1, 2 * r + 1);
  for (auto _ : st) {
    if (st.range(0) == 20) {
      ours.apply(guide, map, out, 0.f, 1.f);
    } else {
      cv::boxFilter(guide, mi, CV_32F, k);
      cv::boxFilter(map, mp, CV_32F, k);
      cv::boxFilter(guide.mul(map), mip, CV_32F, k);
      cv::boxFilter(guide.mul(guide), mii, CV_32F, k);
      a = (mip - mi.mul(mp)) / (mii - mi.mul(mi) + eps);
      b = mp - a.mul(mi);
      cv::boxFilter(a, ma, CV_32F, k);
      cv::boxFilter(b, mb, CV_32F, k);
      out = ma.mul(guide) + mb;
    }
    benchmark::DoNotOptimize(out.data);
  }
}
BENCHMARK(BM_GuidedFilter)->Arg(20)->Arg(21)->Unit(benchmark::kMillisecond);

// The orientation channel's Gabor energy, 4 orientations, on pyramid levels 2..8 of a 640x480
// frame (what one SAMS / Itti call filters): /10 the direct 9x9 pair, /11 the separable form.
void BM_GaborEnergy(benchmark::State& st) {
  const bool separable = st.range(0) == 11;
  cv::Mat level;
  cv::cvtColor(frame({640, 480}), level, cv::COLOR_BGR2GRAY);
  level.convertTo(level, CV_32F, 1.0 / 255.0);
  std::vector<cv::Mat> levels;
  for (int l = 0; l <= 8; ++l) {
    if (l >= 2) levels.push_back(level.clone());
    cv::pyrDown(level, level, cv::Size((level.cols + 1) / 2, (level.rows + 1) / 2));
  }
  std::vector<cv::Mat> even(4), odd(4);
  std::vector<rs::SeparableGabor> sep;
  for (int t = 0; t < 4; ++t) {
    rs::gabor_kernels(9, 7.0 / 3.0, 7.0, 1.0, CV_PI * t / 4, even[t], odd[t]);
    sep.push_back(rs::SeparableGabor::make(9, 7.0 / 3.0, 7.0, CV_PI * t / 4));
  }
  cv::Mat dst, pad, rows;
  rs::GaborLevel shared;  // the separable form pads and sums each level once for its 4 orientations
  for (auto _ : st)
    for (const cv::Mat& l : levels) {
      if (separable) shared.prepare(l, sep[0]);
      for (int t = 0; t < 4; ++t) {
        if (separable)
          rs::gabor_energy(shared, sep[t], dst, rows);
        else
          rs::gabor_energy(l, even[t], odd[t], dst, pad, rows);
        benchmark::DoNotOptimize(dst.data);
      }
    }
}
BENCHMARK(BM_GaborEnergy)->Arg(10)->Arg(11)->Unit(benchmark::kMillisecond);

BENCHMARK(BM_Itti)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Trained)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_TrainedGrey)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_SamsSharedDtm)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Contrast)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_SpectralResidual)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_FineGrained)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

// Collects the per-iteration real time of every run and prints ratios against
// Itti.
class RatioReporter : public benchmark::ConsoleReporter {
 public:
  void ReportRuns(const std::vector<Run>& runs) override {
    ConsoleReporter::ReportRuns(runs);
    for (const auto& r : runs) {
      if (r.run_type == Run::RT_Iteration) {
        times_[r.benchmark_name()] = r.GetAdjustedCPUTime();
        wall_[r.benchmark_name()] = r.GetAdjustedRealTime();
      }
    }
  }
  void Finalize() override {
    ConsoleReporter::Finalize();
    const auto direct = times_.find("BM_GaborEnergy/10"), separable = times_.find("BM_GaborEnergy/11");
    if (direct != times_.end() && separable != times_.end())
      std::printf(
          "\nGabor energy, 4 orientations on levels 2..8 of 640x480: separable %.3f ms, direct %.3f ms CPU: x%.2f\n",
          separable->second, direct->second, separable->second / direct->second);
    const auto gf = times_.find("BM_GuidedFilter/20"), gf_cv = times_.find("BM_GuidedFilter/21");
    if (gf != times_.end() && gf_cv != times_.end())
      std::printf(
          "\nGuided filter of the trained map at 560x500, r 12: %.3f ms, with cv::boxFilter %.3f ms CPU: x%.2f\n",
          gf->second, gf_cv->second, gf->second / gf_cv->second);
    for (const char* size : {"0", "1"}) {
      const auto itti = times_.find(std::string("BM_Itti/") + size);
      if (itti == times_.end()) continue;
      std::printf(
          "\nRatios vs Itti at %s (CPU time / Itti CPU time; Itti = "
          "%.2f ms CPU):\n",
          size[0] == '0' ? "560x500" : "640x480", itti->second);
      for (const auto& [name, t] : times_) {
        if (name.size() > 2 && name.substr(name.size() - 2) == std::string("/") + size) {
          std::printf("  %-24s %8.2f ms CPU  %6.1f fps  x%.2f   (wall %.2f ms)\n", name.c_str(), t, 1000.0 / t,
                      t / itti->second, wall_[name]);
        }
      }
      // The trained detector against its goal's peers (issue 15: >= 30 fps at 560x500).
      const auto trained = times_.find(std::string("BM_Trained/") + size);
      if (trained == times_.end()) continue;
      for (const char* peer_name : {"BM_SamsWithSfs/", "BM_SamsSharedDtm/", "BM_Contrast/"}) {
        const auto p = times_.find(std::string(peer_name) + size);
        if (p != times_.end())
          std::printf("  trained / %-22s x%.2f\n", (std::string(peer_name) + size).c_str(),
                      trained->second / p->second);
      }
    }
  }

 private:
  std::map<std::string, double> times_, wall_;
};

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  RatioReporter rep;
  benchmark::RunSpecifiedBenchmarks(&rep);
  benchmark::Shutdown();
  return 0;
}
