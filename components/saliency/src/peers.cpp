#include "regolith/saliency/peers.hpp"

#include <stdexcept>

#include <opencv2/imgproc.hpp>
#include <opencv2/saliency.hpp>

namespace regolith::saliency {

const char* to_string(Method m) {
  switch (m) {
    case Method::kSams: return "sams";
    case Method::kItti: return "itti";
    case Method::kSpectralResidual: return "spectral_residual";
    case Method::kFineGrained: return "fine_grained";
    case Method::kContrast: return "contrast";
  }
  return "?";
}

std::vector<std::string> method_names() {
  std::vector<std::string> out;
  for (Method m : kAllMethods) out.emplace_back(to_string(m));
  return out;
}

Method method_from_string(const std::string& name) {
  std::string accepted;
  for (Method m : kAllMethods) {
    if (name == to_string(m)) return m;
    accepted += (accepted.empty() ? "" : ", ") + std::string(to_string(m));
  }
  throw std::invalid_argument("method: unknown '" + name + "' (accepted: " + accepted + ")");
}

struct OpenCvSaliency::Impl {
  cv::Ptr<cv::saliency::StaticSaliency> algo;
  cv::Mat bgr8, raw;
};

OpenCvSaliency::OpenCvSaliency(Method method) : method_(method), impl_(std::make_unique<Impl>()) {
  if (method == Method::kSpectralResidual) {
    impl_->algo = cv::saliency::StaticSaliencySpectralResidual::create();
  } else if (method == Method::kFineGrained) {
    impl_->algo = cv::saliency::StaticSaliencyFineGrained::create();
  } else {
    throw std::invalid_argument(std::string("OpenCvSaliency: method '") + to_string(method) +
                                "' is not an OpenCV peer");
  }
}

OpenCvSaliency::~OpenCvSaliency() = default;
OpenCvSaliency::OpenCvSaliency(OpenCvSaliency&&) noexcept = default;
OpenCvSaliency& OpenCvSaliency::operator=(OpenCvSaliency&&) noexcept = default;

void OpenCvSaliency::compute(const cv::Mat& image, cv::Mat& saliency) {
  if (image.empty()) throw std::invalid_argument("image: empty");
  const int ch = image.channels();
  if (ch != 1 && ch != 3 && ch != 4) throw std::invalid_argument("image: must have 1, 3 or 4 channels");
  double scale = 1.0;
  switch (image.depth()) {
    case CV_8U: scale = 1.0; break;
    case CV_16U: scale = 255.0 / 65535.0; break;
    case CV_16S: scale = 255.0 / 32767.0; break;
    case CV_32F:
    case CV_64F: {
      double mx = 0.0;
      cv::minMaxLoc(image.reshape(1), nullptr, &mx);
      scale = mx > 1.0 ? 255.0 / mx : 255.0;
      break;
    }
    default: throw std::invalid_argument("image: unsupported depth");
  }
  cv::Mat& b = impl_->bgr8;
  if (ch == 1) {
    image.convertTo(impl_->raw, CV_8U, scale);
    cv::cvtColor(impl_->raw, b, cv::COLOR_GRAY2BGR);
  } else if (ch == 4) {
    image.convertTo(impl_->raw, CV_8U, scale);
    cv::cvtColor(impl_->raw, b, cv::COLOR_BGRA2BGR);
  } else {
    image.convertTo(b, CV_8U, scale);
  }
  if (!impl_->algo->computeSaliency(b, impl_->raw) || impl_->raw.empty()) {
    throw std::runtime_error(std::string("OpenCV ") + to_string(method_) + " saliency failed");
  }
  cv::Mat& r = impl_->raw;
  if (r.size() != image.size()) cv::resize(r, r, image.size(), 0, 0, cv::INTER_LINEAR);
  double mn = 0.0, mx = 0.0;
  cv::minMaxLoc(r, &mn, &mx);
  if (mx - mn > 0.0)
    r.convertTo(saliency, CV_32F, 1.0 / (mx - mn), -mn / (mx - mn));
  else
    saliency = cv::Mat::zeros(image.size(), CV_32F);
}

}  // namespace regolith::saliency
