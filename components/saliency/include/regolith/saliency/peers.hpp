#pragma once
// Peer saliency methods behind the same post-processing (OpenCV contrib, module
// `saliency`): StaticSaliencySpectralResidual (Hou & Zhang 2007) and
// StaticSaliencyFineGrained (Montabone & Soto 2010). Both return a CV_32F map
// in [0,1] at the input size.
#include <array>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace regolith::saliency {

/// The methods compared by this library (kContrast: contrast.hpp).
enum class Method { kSams, kItti, kSpectralResidual, kFineGrained, kContrast };

/// Every method, in the order of the tables: sams, itti, contrast, spectral_residual,
/// fine_grained.
inline constexpr std::array<Method, 5> kAllMethods{Method::kSams, Method::kItti, Method::kContrast,
                                                   Method::kSpectralResidual, Method::kFineGrained};

/// "sams" | "itti" | "contrast" | "spectral_residual" | "fine_grained".
const char* to_string(Method m);
/// The names of kAllMethods, in that order (for command-line choices).
std::vector<std::string> method_names();
/// Parses the names above; throws std::invalid_argument listing the accepted
/// names.
Method method_from_string(const std::string& name);

/// Wrapper around one OpenCV static saliency algorithm. Converts any
/// 1/3/4-channel 8U/16U/32F input to 8-bit BGR first, min-max normalises the
/// output to [0,1] (a constant map -> zeros).
class OpenCvSaliency {
 public:
  /// `method` must be kSpectralResidual or kFineGrained (std::invalid_argument
  /// otherwise).
  explicit OpenCvSaliency(Method method);
  ~OpenCvSaliency();
  OpenCvSaliency(OpenCvSaliency&&) noexcept;
  OpenCvSaliency& operator=(OpenCvSaliency&&) noexcept;

  /// Throws std::invalid_argument on empty / unsupported input,
  /// std::runtime_error if OpenCV fails.
  void compute(const cv::Mat& image, cv::Mat& saliency);
  Method method() const { return method_; }

 private:
  struct Impl;
  Method method_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace regolith::saliency
