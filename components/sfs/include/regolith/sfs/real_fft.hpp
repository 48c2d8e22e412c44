#pragma once
// A 2-D real <-> half-complex FFT of one fixed size, over FFTW single-precision plans made once.
//
// cv::dft builds its plan and scratch buffers on the heap at every call (~29 allocations per
// 640x480 Pentland solve), which a rate-group cycle must not do. Here `resize` makes the plans and
// the FFTW-aligned buffers (configure time, or the first frame of a size); `forward` / `inverse`
// then only execute them: no heap allocation, no locking.
#include <opencv2/core.hpp>

namespace regolith::sfs {

class RealFft2d {
 public:
  RealFft2d() = default;
  RealFft2d(int rows, int cols) { resize(rows, cols); }
  ~RealFft2d();
  /// A copy makes its own plans and buffers of the same size (contents are not copied).
  RealFft2d(const RealFft2d& other);
  RealFft2d& operator=(const RealFft2d& other);
  RealFft2d(RealFft2d&& other) noexcept;
  RealFft2d& operator=(RealFft2d&& other) noexcept;

  /// Plans for a rows x cols real array (both >= 1); a no-op when the size is unchanged. Plans are
  /// made with FFTW_ESTIMATE (deterministic, no timing runs) under a process-wide lock, since the
  /// FFTW planner is not thread-safe. Throws std::invalid_argument on a bad size and
  /// std::runtime_error if FFTW cannot plan.
  void resize(int rows, int cols);
  int rows() const { return rows_; }
  int cols() const { return cols_; }

  /// rows x cols CV_32F view of the real buffer (input of forward, output of inverse).
  cv::Mat real() const;
  /// rows x (cols / 2 + 1) CV_32FC2 view of the half spectrum (output of forward, input of
  /// inverse): element (r, c) is frequency (r, c); the columns cols/2+1.. are the conjugates.
  cv::Mat spectrum() const;

  /// real -> spectrum (unnormalised).
  void forward();
  /// spectrum -> real, unnormalised (the result is rows * cols times the input of forward);
  /// the spectrum is overwritten.
  void inverse();

 private:
  void release();
  int rows_ = 0, cols_ = 0;
  float* real_ = nullptr;
  void* spectrum_ = nullptr;      // fftwf_complex*
  void* forward_plan_ = nullptr;  // fftwf_plan
  void* inverse_plan_ = nullptr;
};

}  // namespace regolith::sfs
