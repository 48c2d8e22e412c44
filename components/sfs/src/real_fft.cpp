#include "regolith/sfs/real_fft.hpp"

#include <mutex>
#include <stdexcept>
#include <string>
#include <utility>

#include <fftw3.h>

namespace regolith::sfs {
namespace {

// FFTW's planner (and plan destruction) share global state: one lock for every instance.
std::mutex& planner_mutex() {
  static std::mutex m;
  return m;
}

}  // namespace

RealFft2d::~RealFft2d() {
  release();
}

RealFft2d::RealFft2d(const RealFft2d& other) {
  if (other.rows_ > 0) resize(other.rows_, other.cols_);
}

RealFft2d& RealFft2d::operator=(const RealFft2d& other) {
  if (this != &other) {
    if (other.rows_ > 0)
      resize(other.rows_, other.cols_);
    else
      release();
  }
  return *this;
}

RealFft2d::RealFft2d(RealFft2d&& other) noexcept
    : rows_(std::exchange(other.rows_, 0)),
      cols_(std::exchange(other.cols_, 0)),
      real_(std::exchange(other.real_, nullptr)),
      spectrum_(std::exchange(other.spectrum_, nullptr)),
      forward_plan_(std::exchange(other.forward_plan_, nullptr)),
      inverse_plan_(std::exchange(other.inverse_plan_, nullptr)) {}

RealFft2d& RealFft2d::operator=(RealFft2d&& other) noexcept {
  if (this != &other) {
    release();
    rows_ = std::exchange(other.rows_, 0);
    cols_ = std::exchange(other.cols_, 0);
    real_ = std::exchange(other.real_, nullptr);
    spectrum_ = std::exchange(other.spectrum_, nullptr);
    forward_plan_ = std::exchange(other.forward_plan_, nullptr);
    inverse_plan_ = std::exchange(other.inverse_plan_, nullptr);
  }
  return *this;
}

void RealFft2d::release() {
  if (forward_plan_ != nullptr || inverse_plan_ != nullptr) {
    const std::lock_guard<std::mutex> lock(planner_mutex());
    if (forward_plan_ != nullptr) fftwf_destroy_plan(static_cast<fftwf_plan>(forward_plan_));
    if (inverse_plan_ != nullptr) fftwf_destroy_plan(static_cast<fftwf_plan>(inverse_plan_));
  }
  forward_plan_ = inverse_plan_ = nullptr;
  fftwf_free(real_);
  fftwf_free(spectrum_);
  real_ = nullptr;
  spectrum_ = nullptr;
  rows_ = cols_ = 0;
}

void RealFft2d::resize(int rows, int cols) {
  if (rows < 1 || cols < 1)
    throw std::invalid_argument("fft: size must be at least 1x1 (got " + std::to_string(rows) + "x" +
                                std::to_string(cols) + ")");
  if (rows == rows_ && cols == cols_) return;
  release();
  const size_t n_real = static_cast<size_t>(rows) * static_cast<size_t>(cols);
  const size_t n_half = static_cast<size_t>(rows) * static_cast<size_t>(cols / 2 + 1);
  real_ = fftwf_alloc_real(n_real);
  auto* spec = fftwf_alloc_complex(n_half);
  spectrum_ = spec;
  if (real_ == nullptr || spec == nullptr) {
    release();
    throw std::runtime_error("fft: out of memory for a " + std::to_string(rows) + "x" + std::to_string(cols) +
                             " transform");
  }
  {
    const std::lock_guard<std::mutex> lock(planner_mutex());
    forward_plan_ = fftwf_plan_dft_r2c_2d(rows, cols, real_, spec, FFTW_ESTIMATE);
    inverse_plan_ = fftwf_plan_dft_c2r_2d(rows, cols, spec, real_, FFTW_ESTIMATE);
  }
  rows_ = rows;
  cols_ = cols;
  if (forward_plan_ == nullptr || inverse_plan_ == nullptr) {
    release();
    throw std::runtime_error("fft: FFTW could not plan a " + std::to_string(rows) + "x" + std::to_string(cols) +
                             " transform");
  }
}

cv::Mat RealFft2d::real() const {
  return cv::Mat(rows_, cols_, CV_32F, real_);
}

cv::Mat RealFft2d::spectrum() const {
  return cv::Mat(rows_, cols_ / 2 + 1, CV_32FC2, spectrum_);
}

void RealFft2d::forward() {
  if (forward_plan_ != nullptr) fftwf_execute(static_cast<fftwf_plan>(forward_plan_));
}

void RealFft2d::inverse() {
  if (inverse_plan_ != nullptr) fftwf_execute(static_cast<fftwf_plan>(inverse_plan_));
}

}  // namespace regolith::sfs
