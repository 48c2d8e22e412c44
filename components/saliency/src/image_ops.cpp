#include "regolith/saliency/image_ops.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>
#include <type_traits>

#include <opencv2/core/hal/intrin.hpp>
#include <opencv2/imgproc.hpp>

namespace regolith::saliency {

void to_unit_float(const cv::Mat& image, cv::Mat& out) {
  double scale = 1.0;
  switch (image.depth()) {
    case CV_8U: scale = 1.0 / 255.0; break;
    case CV_16U: scale = 1.0 / 65535.0; break;
    case CV_16S: scale = 1.0 / 32767.0; break;
    case CV_32F:
    case CV_64F: {
      double mx = 0.0;
      cv::minMaxLoc(image.reshape(1), nullptr, &mx);
      if (!std::isfinite(mx)) throw std::invalid_argument("image: contains NaN or infinity");
      scale = mx > 1.0 ? 1.0 / mx : 1.0;
      break;
    }
    default: throw std::invalid_argument("image: unsupported depth (use 8U, 16U, 16S, 32F or 64F)");
  }
  image.convertTo(out, CV_32F, scale);
  if (image.depth() == CV_16S || image.depth() == CV_32F || image.depth() == CV_64F) {
    cv::threshold(out, out, 0.0, 0.0, cv::THRESH_TOZERO);
  }
}

void intensity_of(const cv::Mat& unit, cv::Mat& intensity) {
  const int ch = unit.channels();
  if (unit.depth() != CV_32F || (ch != 1 && ch != 3 && ch != 4)) {
    throw std::invalid_argument("intensity_of: input must be CV_32F with 1, 3 or 4 channels");
  }
  if (ch == 1) {
    unit.copyTo(intensity);
  } else if (ch == 3) {
    const cv::Matx<float, 1, 3> m3(1.f / 3, 1.f / 3, 1.f / 3);
    cv::transform(unit, intensity, m3);
  } else {
    const cv::Matx<float, 1, 4> m4(1.f / 3, 1.f / 3, 1.f / 3, 0.f);
    cv::transform(unit, intensity, m4);
  }
}

namespace {

// Copies `src` into the centre of `pad` (rows + 2 ry, cols + 2 rx) and fills the margin by
// replicating the nearest image pixel (cv::BORDER_REPLICATE).
void pad_replicate_32f(const cv::Mat& src, cv::Mat& pad, int rx, int ry) {
  const int w = src.cols, h = src.rows;
  pad.create(h + 2 * ry, w + 2 * rx, CV_32F);
  for (int y = 0; y < h; ++y) {
    const float* s = src.ptr<float>(y);
    float* p = pad.ptr<float>(y + ry);
    for (int x = 0; x < rx; ++x) {
      p[x] = s[0];
      p[rx + w + x] = s[w - 1];
    }
    std::copy(s, s + w, p + rx);
  }
  for (int y = 0; y < ry; ++y) {
    const float* top = pad.ptr<float>(ry);
    const float* bottom = pad.ptr<float>(ry + h - 1);
    std::copy(top, top + pad.cols, pad.ptr<float>(y));
    std::copy(bottom, bottom + pad.cols, pad.ptr<float>(ry + h + y));
  }
}

void check_kernel(const cv::Mat& k, const char* what) {
  if (k.type() != CV_32FC1 || k.rows % 2 == 0 || k.cols % 2 == 0)
    throw std::invalid_argument(std::string(what) + ": kernel must be CV_32FC1 of odd size");
}

}  // namespace

void gabor_energy(const cv::Mat& src, const cv::Mat& even, const cv::Mat& odd, cv::Mat& dst, cv::Mat& pad,
                  cv::Mat& rows) {
  if (src.type() != CV_32FC1 || src.empty())
    throw std::invalid_argument("gabor_energy: image must be non-empty CV_32FC1");
  check_kernel(even, "gabor_energy");
  check_kernel(odd, "gabor_energy");
  if (even.size() != odd.size()) throw std::invalid_argument("gabor_energy: even and odd kernels differ in size");
  const int w = src.cols, h = src.rows, kw = even.cols, kh = even.rows;
  pad_replicate_32f(src, pad, kw / 2, kh / 2);
  rows.create(2, w, CV_32F);
  dst.create(h, w, CV_32F);
  float* e = rows.ptr<float>(0);
  float* o = rows.ptr<float>(1);
  // Blocks of kBlock output pixels keep their two sums in registers over all taps (one load of
  // the image per tap pair instead of two loads and two stores of the sums); every pixel still
  // adds its taps in row-major order from 0, so the result is the same bit for bit.
  // OpenCV's universal intrinsics (SSE2 / NEON), as the SfS march: a multiply then an add per tap
  // in every lane, the scalar code's operations in its order.
  using V4 = cv::v_float32x4;
  constexpr int kVecs = 4, kBlock = V4::nlanes * kVecs;
  const int wb = w - w % kBlock;
  for (int y = 0; y < h; ++y) {
    float* d = dst.ptr<float>(y);
    for (int x0 = 0; x0 < wb; x0 += kBlock) {
      V4 se[kVecs], so[kVecs];
      for (int k = 0; k < kVecs; ++k) se[k] = so[k] = cv::v_setzero_f32();
      for (int i = 0; i < kh; ++i) {
        const float* ke = even.ptr<float>(i);
        const float* ko = odd.ptr<float>(i);
        const float* p = pad.ptr<float>(y + i) + x0;
        for (int j = 0; j < kw; ++j) {
          const V4 a = cv::v_setall_f32(ke[j]), b = cv::v_setall_f32(ko[j]);
          for (int k = 0; k < kVecs; ++k) {
            const V4 q = cv::v_load(p + j + V4::nlanes * k);
            se[k] = se[k] + a * q;
            so[k] = so[k] + b * q;
          }
        }
      }
      for (int k = 0; k < kVecs; ++k) cv::v_store(d + x0 + V4::nlanes * k, cv::v_abs(se[k]) + cv::v_abs(so[k]));
    }
    if (wb == w) continue;
    std::fill(e + wb, e + w, 0.f);
    std::fill(o + wb, o + w, 0.f);
    for (int i = 0; i < kh; ++i) {
      const float* ke = even.ptr<float>(i);
      const float* ko = odd.ptr<float>(i);
      const float* p = pad.ptr<float>(y + i);
      for (int j = 0; j < kw; ++j) {
        const float a = ke[j], b = ko[j];
        const float* q = p + j;
        for (int x = wb; x < w; ++x) {
          e[x] += a * q[x];
          o[x] += b * q[x];
        }
      }
    }
    for (int x = wb; x < w; ++x) d[x] = std::abs(e[x]) + std::abs(o[x]);
  }
}

void gabor_kernels(int size, double sigma, double period, double elongation, double theta_rad, cv::Mat& even,
                   cv::Mat& odd) {
  const int hw = size / 2;
  for (int phase = 0; phase < 2; ++phase) {
    cv::Mat k(size, size, CV_32F);
    const double phi = phase == 0 ? 0.0 : std::numbers::pi / 2;
    for (int y = -hw; y <= hw; ++y)
      for (int x = -hw; x <= hw; ++x) {
        const double xr = x * std::cos(theta_rad) + y * std::sin(theta_rad);
        const double yr = -x * std::sin(theta_rad) + y * std::cos(theta_rad);
        const double env = std::exp(-(xr * xr + elongation * elongation * yr * yr) / (2.0 * sigma * sigma));
        k.at<float>(y + hw, x + hw) = static_cast<float>(env * std::cos(2.0 * std::numbers::pi * xr / period + phi));
      }
    k -= cv::mean(k)[0];
    const double norm = cv::norm(k, cv::NORM_L2);
    if (norm > 0) k /= norm;
    (phase == 0 ? even : odd) = k;
  }
}

SeparableGabor SeparableGabor::make(int size, double sigma, double period, double theta_rad) {
  if (size < 1 || size % 2 == 0) throw std::invalid_argument("SeparableGabor: size must be odd and >= 1");
  if (!(sigma > 0.0) || !(period > 0.0)) throw std::invalid_argument("SeparableGabor: sigma and period must be > 0");
  const int hw = size / 2;
  const double w = 2.0 * std::numbers::pi / period, a = w * std::cos(theta_rad), b = w * std::sin(theta_rad);
  SeparableGabor k;
  for (auto* v : {&k.row_re, &k.row_im, &k.col_re, &k.col_im}) v->resize(static_cast<std::size_t>(size));
  for (int t = -hw; t <= hw; ++t) {
    const double g = std::exp(-t * t / (2.0 * sigma * sigma));
    const auto i = static_cast<std::size_t>(t + hw);
    k.row_re[i] = static_cast<float>(g * std::cos(a * t));
    k.row_im[i] = static_cast<float>(g * std::sin(a * t));
    k.col_re[i] = static_cast<float>(g * std::cos(b * t));
    k.col_im[i] = static_cast<float>(g * std::sin(b * t));
  }
  // The means and norms of the 2-D kernels (in double): even = Re K, odd = -Im K before them.
  double se = 0, so = 0, se2 = 0, so2 = 0;
  for (int y = -hw; y <= hw; ++y)
    for (int x = -hw; x <= hw; ++x) {
      const double g = std::exp(-(x * x + y * y) / (2.0 * sigma * sigma)), ph = a * x + b * y;
      const double e = g * std::cos(ph), o = -g * std::sin(ph);
      se += e, so += o, se2 += e * e, so2 += o * o;
    }
  const double n = static_cast<double>(size) * size, me = se / n, mo = so / n;
  const double ne = std::sqrt(std::max(0.0, se2 - n * me * me)), no = std::sqrt(std::max(0.0, so2 - n * mo * mo));
  k.mean_even = static_cast<float>(me);
  k.mean_odd = static_cast<float>(mo);
  k.inv_norm_even = ne > 0 ? static_cast<float>(1.0 / ne) : 1.0f;
  k.inv_norm_odd = no > 0 ? static_cast<float>(1.0 / no) : 1.0f;
  return k;
}

namespace {

void check_separable(const SeparableGabor& k) {
  const int n = k.size();
  if (n < 1 || n % 2 == 0 || k.row_im.size() != k.row_re.size() || k.col_re.size() != k.row_re.size() ||
      k.col_im.size() != k.row_re.size())
    throw std::invalid_argument("gabor_energy: the separable kernel's taps must be odd in number and match");
}

// The kernels make() builds are even in their real and odd in their imaginary taps: then tap pairs
// (j, n - 1 - j) share one multiply per part (sum and difference of the two pixels).
bool is_folded(const SeparableGabor& k) {
  const int n = k.size(), r = n / 2;
  bool folded = true;
  for (int j = 0; j <= r; ++j) {
    const auto m = static_cast<std::size_t>(n - 1 - j), i = static_cast<std::size_t>(j);
    folded = folded && k.row_re[i] == k.row_re[m] && k.row_im[i] == -k.row_im[m] && k.col_re[i] == k.col_re[m] &&
             k.col_im[i] == -k.col_im[m];
  }
  return folded;
}

// Blocks of kBlock pixels keep their sums in registers over all taps (the pixels from the last
// whole block on are summed one by one).
using V4 = cv::v_float32x4;
constexpr int kVecs = 4, kLanes = V4::nlanes, kBlock = kLanes * kVecs;

}  // namespace

void GaborLevel::prepare(const cv::Mat& src, const SeparableGabor& k) {
  if (src.type() != CV_32FC1 || src.empty())
    throw std::invalid_argument("gabor_energy: image must be non-empty CV_32FC1");
  check_separable(k);
  const int n = k.size(), w = src.cols, h = src.rows, r = n / 2, ph = h + 2 * r;
  taps = n;
  folded = is_folded(k);
  size = src.size();
  pad_replicate_32f(src, pad, r, r);
  // The n x n window sums, in the order the filtering sums its taps: tap pairs from the outside
  // in then the centre where folded, else tap by tap, over the rows then down the columns; the
  // pixels from the last whole block on tap by tap.
  const int wb = folded ? w - w % kBlock : 0;  // pixels [0, wb) in tap pairs, the rest tap by tap
  // One tap (or tap pair) at a time over a whole run of pixels: the inner loops vectorise, and
  // each pixel's sum still adds its taps in the filtering's order.
  const auto sum_taps = [&](float* o, auto&& at) {  // at(t): row of tap t's pixels, aligned with o
    std::fill(o, o + w, 0.0f);
    for (int j = 0; j < r && wb > 0; ++j) {
      const float *a = at(j), *b = at(n - 1 - j);
      for (int x = 0; x < wb; ++x) o[x] = o[x] + (a[x] + b[x]);
    }
    if (wb > 0) {
      const float* c = at(r);
      for (int x = 0; x < wb; ++x) o[x] = o[x] + c[x];
    }
    for (int j = 0; j < n && wb < w; ++j) {
      const float* a = at(j);
      for (int x = wb; x < w; ++x) o[x] += a[x];
    }
  };
  rows.create(ph, w, CV_32F);
  for (int y = 0; y < ph; ++y) {
    const float* p = pad.ptr<float>(y);
    sum_taps(rows.ptr<float>(y), [&](int t) { return p + t; });
  }
  box.create(h, w, CV_32F);
  for (int y = 0; y < h; ++y) sum_taps(box.ptr<float>(y), [&](int t) { return rows.ptr<float>(y + t); });
}

void gabor_energy(const cv::Mat& src, const SeparableGabor& k, cv::Mat& dst, GaborLevel& level, cv::Mat& rows) {
  level.prepare(src, k);
  gabor_energy(level, k, dst, rows);
}

void gabor_energy(const GaborLevel& level, const SeparableGabor& k, cv::Mat& dst, cv::Mat& rows) {
  check_separable(k);
  if (level.pad.empty() || k.size() != level.taps || is_folded(k) != level.folded)
    throw std::invalid_argument("gabor_energy: the level was prepared for a kernel of another size or symmetry");
  const cv::Mat& pad = level.pad;
  const int n = k.size(), w = level.size.width, h = level.size.height, r = n / 2, ph = h + 2 * r;
  // Rows [0, ph): real part, [ph, 2 ph): imaginary part, of the row pass.
  rows.create(2 * ph, w, CV_32F);
  const float *xr = k.row_re.data(), *xi = k.row_im.data(), *yr = k.col_re.data(), *yi = k.col_im.data();
  const int wb = w - w % kBlock;
  const bool folded = level.folded;
  for (int y = 0; y < ph; ++y) {
    const float* p = pad.ptr<float>(y);
    float* re = rows.ptr<float>(y);
    float* im = rows.ptr<float>(ph + y);
    for (int x0 = 0; x0 < wb; x0 += kBlock) {
      V4 sr[kVecs], si[kVecs];
      for (int v = 0; v < kVecs; ++v) sr[v] = si[v] = cv::v_setzero_f32();
      if (folded) {
        for (int j = 0; j < r; ++j) {
          const V4 a = cv::v_setall_f32(xr[j]), b = cv::v_setall_f32(xi[j]);
          for (int v = 0; v < kVecs; ++v) {
            const V4 q0 = cv::v_load(p + x0 + j + kLanes * v), q1 = cv::v_load(p + x0 + n - 1 - j + kLanes * v);
            const V4 sum = q0 + q1;
            sr[v] = sr[v] + a * sum;
            si[v] = si[v] + b * (q0 - q1);
          }
        }
        const V4 a = cv::v_setall_f32(xr[r]);
        for (int v = 0; v < kVecs; ++v) {
          const V4 q = cv::v_load(p + x0 + r + kLanes * v);
          sr[v] = sr[v] + a * q;
        }
      }
      for (int j = 0; j < (folded ? 0 : n); ++j) {
        const V4 a = cv::v_setall_f32(xr[j]), b = cv::v_setall_f32(xi[j]);
        for (int v = 0; v < kVecs; ++v) {
          const V4 q = cv::v_load(p + x0 + j + kLanes * v);
          sr[v] = sr[v] + a * q;
          si[v] = si[v] + b * q;
        }
      }
      for (int v = 0; v < kVecs; ++v) {
        cv::v_store(re + x0 + kLanes * v, sr[v]);
        cv::v_store(im + x0 + kLanes * v, si[v]);
      }
    }
    for (int x = wb; x < w; ++x) {
      float sr = 0.0f, si = 0.0f;
      for (int j = 0; j < n; ++j) {
        sr += xr[j] * p[x + j];
        si += xi[j] * p[x + j];
      }
      re[x] = sr, im[x] = si;
    }
  }
  dst.create(h, w, CV_32F);
  const float me = k.mean_even, mo = k.mean_odd, ie = k.inv_norm_even, io = k.inv_norm_odd;
  const auto energy = [&](float cre, float cim, float s) {
    return std::abs((cre - me * s) * ie) + std::abs((-cim - mo * s) * io);
  };
  const V4 vme = cv::v_setall_f32(me), vmo = cv::v_setall_f32(mo), vie = cv::v_setall_f32(ie),
           vio = cv::v_setall_f32(io);
  for (int y = 0; y < h; ++y) {
    float* d = dst.ptr<float>(y);
    const float* sums = level.box.ptr<float>(y);  // the window sums the kernels' means apply to
    for (int x0 = 0; x0 < wb; x0 += kBlock) {
      V4 cr[kVecs], ci[kVecs];
      for (int v = 0; v < kVecs; ++v) cr[v] = ci[v] = cv::v_setzero_f32();
      if (folded) {
        for (int i = 0; i < r; ++i) {
          const V4 a = cv::v_setall_f32(yr[i]), b = cv::v_setall_f32(yi[i]);
          const int m = n - 1 - i;
          const float *re0 = rows.ptr<float>(y + i) + x0, *re1 = rows.ptr<float>(y + m) + x0;
          const float *im0 = rows.ptr<float>(ph + y + i) + x0, *im1 = rows.ptr<float>(ph + y + m) + x0;
          for (int v = 0; v < kVecs; ++v) {
            const V4 r0 = cv::v_load(re0 + kLanes * v), r1 = cv::v_load(re1 + kLanes * v);
            const V4 i0 = cv::v_load(im0 + kLanes * v), i1 = cv::v_load(im1 + kLanes * v);
            cr[v] = cr[v] + (a * (r0 + r1) - b * (i0 - i1));
            ci[v] = ci[v] + (a * (i0 + i1) + b * (r0 - r1));
          }
        }
        const V4 a = cv::v_setall_f32(yr[r]);
        const float* re = rows.ptr<float>(y + r) + x0;
        const float* im = rows.ptr<float>(ph + y + r) + x0;
        for (int v = 0; v < kVecs; ++v) {
          cr[v] = cr[v] + a * cv::v_load(re + kLanes * v);
          ci[v] = ci[v] + a * cv::v_load(im + kLanes * v);
        }
      }
      for (int i = 0; i < (folded ? 0 : n); ++i) {
        const V4 a = cv::v_setall_f32(yr[i]), b = cv::v_setall_f32(yi[i]);
        const float* re = rows.ptr<float>(y + i) + x0;
        const float* im = rows.ptr<float>(ph + y + i) + x0;
        for (int v = 0; v < kVecs; ++v) {
          const V4 qr = cv::v_load(re + kLanes * v), qi = cv::v_load(im + kLanes * v);
          cr[v] = cr[v] + (a * qr - b * qi);
          ci[v] = ci[v] + (a * qi + b * qr);
        }
      }
      // energy() lane by lane, the same operations in the same order
      for (int v = 0; v < kVecs; ++v) {
        const V4 cs = cv::v_load(sums + x0 + kLanes * v);
        const V4 even = (cr[v] - vme * cs) * vie, odd = (cv::v_setzero_f32() - ci[v] - vmo * cs) * vio;
        cv::v_store(d + x0 + kLanes * v, cv::v_abs(even) + cv::v_abs(odd));
      }
    }
    for (int x = wb; x < w; ++x) {
      float cre = 0.0f, cim = 0.0f;
      for (int i = 0; i < n; ++i) {
        const float qr = rows.ptr<float>(y + i)[x], qi = rows.ptr<float>(ph + y + i)[x];
        cre += yr[i] * qr - yi[i] * qi;
        cim += yr[i] * qi + yi[i] * qr;
      }
      d[x] = energy(cre, cim, sums[x]);
    }
  }
}

void correlate_replicate(const cv::Mat& src, const cv::Mat& kernel, cv::Mat& dst, cv::Mat& pad) {
  if (src.type() != CV_32FC1 || src.empty())
    throw std::invalid_argument("correlate_replicate: image must be non-empty CV_32FC1");
  check_kernel(kernel, "correlate_replicate");
  const int w = src.cols, h = src.rows, kw = kernel.cols, kh = kernel.rows;
  pad_replicate_32f(src, pad, kw / 2, kh / 2);
  dst.create(h, w, CV_32F);
  for (int y = 0; y < h; ++y) {
    float* d = dst.ptr<float>(y);
    std::fill(d, d + w, 0.f);
    for (int i = 0; i < kh; ++i) {
      const float* k = kernel.ptr<float>(i);
      const float* p = pad.ptr<float>(y + i);
      for (int j = 0; j < kw; ++j) {
        if (k[j] == 0.f) continue;
        const float a = k[j];
        const float* q = p + j;
        for (int x = 0; x < w; ++x) d[x] += a * q[x];
      }
    }
  }
}

// ---- ResizeTable ----

void ResizeTable::build_linear(int src, int dst, Axis& a) {
  // cv::resize INTER_LINEAR: source coordinate of output pixel d is (d + 0.5) * scale - 0.5,
  // taps floor(f) and floor(f) + 1 with weights 1 - frac, frac; clamped to the edge pixel
  // (weight 1) outside the image.
  const double scale = 1.0 / (static_cast<double>(dst) / src);
  a.begin.assign(static_cast<std::size_t>(dst) + 1, 0);
  a.index.clear();
  a.weight.clear();
  for (int d = 0; d < dst; ++d) {
    float f = static_cast<float>((d + 0.5) * scale - 0.5);
    int s = static_cast<int>(std::floor(f));
    f -= static_cast<float>(s);
    if (s < 0) {
      f = 0.f;
      s = 0;
    }
    if (s >= src - 1) {
      f = 0.f;
      s = src - 1;
    }
    a.index.push_back(s);
    a.weight.push_back(1.f - f);
    a.index.push_back(std::min(s + 1, src - 1));
    a.weight.push_back(f);
    a.begin[static_cast<std::size_t>(d) + 1] = static_cast<int>(a.index.size());
  }
}

void ResizeTable::build_area(int src, int dst, Axis& a) {
  // cv::resize INTER_AREA (downscaling): output pixel d averages the source interval
  // [d * scale, (d + 1) * scale), partial pixels at both ends weighted by their overlap.
  const double scale = static_cast<double>(src) / dst;
  a.begin.assign(static_cast<std::size_t>(dst) + 1, 0);
  a.index.clear();
  a.weight.clear();
  for (int d = 0; d < dst; ++d) {
    const double f1 = d * scale, f2 = f1 + scale;
    const double cell = std::min(scale, src - f1);
    int s1 = static_cast<int>(std::ceil(f1)), s2 = static_cast<int>(std::floor(f2));
    s2 = std::min(s2, src - 1);
    s1 = std::min(s1, s2);
    if (s1 - f1 > 1e-3) {
      a.index.push_back(s1 - 1);
      a.weight.push_back(static_cast<float>((s1 - f1) / cell));
    }
    for (int s = s1; s < s2; ++s) {
      a.index.push_back(s);
      a.weight.push_back(static_cast<float>(1.0 / cell));
    }
    if (f2 - s2 > 1e-3) {
      a.index.push_back(s2);
      a.weight.push_back(static_cast<float>(std::min(std::min(f2 - s2, 1.0), cell) / cell));
    }
    a.begin[static_cast<std::size_t>(d) + 1] = static_cast<int>(a.index.size());
  }
}

void ResizeTable::build(cv::Size src, cv::Size dst, Mode mode) {
  if (src.width <= 0 || src.height <= 0 || dst.width <= 0 || dst.height <= 0)
    throw std::invalid_argument("ResizeTable: empty size");
  src_ = src;
  dst_ = dst;
  if (mode == Mode::kArea) {
    if (dst.width > src.width || dst.height > src.height)
      throw std::invalid_argument("ResizeTable: area mode only downscales");
    build_area(src.width, dst.width, x_);
    build_area(src.height, dst.height, y_);
  } else {
    build_linear(src.width, dst.width, x_);
    build_linear(src.height, dst.height, y_);
  }
  rows_.create(src.height, dst.width, CV_32F);
  x_taps_ = x_.begin[1];  // the taps of every output, when they are all alike; else 0
  for (std::size_t d = 1; d + 1 < x_.begin.size() && x_taps_ != 0; ++d)
    if (x_.begin[d + 1] - x_.begin[d] != x_taps_) x_taps_ = 0;
}

void ResizeTable::apply(const cv::Mat& src, cv::Mat& dst, bool clamp_unit) {
  if (src.type() != CV_32FC1 || src.size() != src_)
    throw std::invalid_argument("ResizeTable::apply: source must be CV_32FC1 of the built size");
  dst.create(dst_, CV_32F);
  const int dw = dst_.width;
  const int* xb = x_.begin.data();
  const int* xi = x_.index.data();
  const float* xw = x_.weight.data();
  // Along the rows: each output the sum of its taps' products from 0, in tap order. With the same
  // number of taps for every output (a linear table; an area table of a whole-number scale) the
  // count is a constant of the loop, which the compiler unrolls: same sums, less loop overhead.
  // kTaps 0: each output's own count, from the table's begin offsets.
  const auto along_rows = [&](auto taps) {
    constexpr int kTaps = decltype(taps)::value;
    for (int y = 0; y < src_.height; ++y) {
      const float* s = src.ptr<float>(y);
      float* r = rows_.ptr<float>(y);
      for (int d = 0; d < dw; ++d) {
        float acc = 0.f;
        if constexpr (kTaps > 0)
          for (int t = 0; t < kTaps; ++t) acc += xw[d * kTaps + t] * s[xi[d * kTaps + t]];
        else
          for (int k = xb[d]; k < xb[d + 1]; ++k) acc += xw[k] * s[xi[k]];
        r[d] = acc;
      }
    }
  };
  switch (x_taps_) {
    case 2: along_rows(std::integral_constant<int, 2>{}); break;
    case 3: along_rows(std::integral_constant<int, 3>{}); break;
    case 4: along_rows(std::integral_constant<int, 4>{}); break;
    default: along_rows(std::integral_constant<int, 0>{});
  }
  // Down the columns: the first tap's product, then each further tap's (a zero weight skipped),
  // in that order; a row of one or two taps (every row of a linear table) in one pass.
  // Into [0, 1], NaN -> 0; written as max then min, each the form of one SSE / NEON instruction.
  const auto unit = [](float v) {
    const float lo = v > 0.f ? v : 0.f;
    return lo < 1.f ? lo : 1.f;
  };
  const auto same = [](float v) { return v; };
  for (int d = 0; d < dst_.height; ++d) {
    float* o = dst.ptr<float>(d);
    const int k0 = y_.begin[static_cast<std::size_t>(d)];
    const int k1 = y_.begin[static_cast<std::size_t>(d) + 1];
    const float b = y_.weight[static_cast<std::size_t>(k0)];
    const float* r = rows_.ptr<float>(y_.index[static_cast<std::size_t>(k0)]);
    if (k1 - k0 <= 2) {
      const float b1 = k1 - k0 == 2 ? y_.weight[static_cast<std::size_t>(k0) + 1] : 0.f;
      const float* r1 = b1 != 0.f ? rows_.ptr<float>(y_.index[static_cast<std::size_t>(k0) + 1]) : nullptr;
      const auto write = [&](auto finish) {  // one loop per case, each vectorisable
        if (r1 != nullptr)
          for (int x = 0; x < dw; ++x) o[x] = finish(b * r[x] + b1 * r1[x]);
        else
          for (int x = 0; x < dw; ++x) o[x] = finish(b * r[x]);
      };
      clamp_unit ? write(unit) : write(same);
      continue;
    }
    for (int x = 0; x < dw; ++x) o[x] = b * r[x];
    for (int k = k0 + 1; k < k1; ++k) {
      const float bk = y_.weight[static_cast<std::size_t>(k)];
      if (bk == 0.f) continue;
      const float* rk = rows_.ptr<float>(y_.index[static_cast<std::size_t>(k)]);
      for (int x = 0; x < dw; ++x) o[x] += bk * rk[x];
    }
    if (clamp_unit)
      for (int x = 0; x < dw; ++x) o[x] = unit(o[x]);
  }
}

// ---- GaussianBlur32f, sobel3_32f ----

void GaussianBlur32f::apply(const cv::Mat& src, cv::Mat& dst, double sigma) {
  if (!std::isfinite(sigma) || sigma <= 0.0) throw std::invalid_argument("GaussianBlur32f: sigma must be > 0");
  if (src.empty() || src.type() != CV_32FC1)
    throw std::invalid_argument("GaussianBlur32f: src must be a non-empty CV_32FC1 image");
  if (sigma != sigma_ || kernel_.empty()) {
    const int ksize = cvRound(sigma * 4 * 2 + 1) | 1;  // OpenCV's size for non-8U images
    const cv::Mat k = cv::getGaussianKernel(ksize, sigma, CV_32F);
    kernel_.assign(k.ptr<float>(0), k.ptr<float>(0) + ksize);  // symmetric: k[t] = k[ksize - 1 - t]
    sigma_ = sigma;
  }
  const int W = src.cols, H = src.rows;
  const int r = static_cast<int>(kernel_.size() / 2);
  const int taps = 2 * r + 1;
  line_.resize(static_cast<std::size_t>(W + 2 * r));  // no-op once sized
  rows_.create(H, W, CV_32F);
  const float* k = kernel_.data();
  for (int y = 0; y < H; ++y) {
    const float* s = src.ptr<float>(y);
    float* l = line_.data();
    std::copy(s, s + W, l + r);  // the row, then its reflected margins
    for (int x = -r; x < 0; ++x) l[x + r] = s[cv::borderInterpolate(x, W, cv::BORDER_REFLECT_101)];
    for (int x = W; x < W + r; ++x) l[x + r] = s[cv::borderInterpolate(x, W, cv::BORDER_REFLECT_101)];
    float* o = rows_.ptr<float>(y);
    // tap by tap over the whole row (the inner loop vectorises), the symmetric taps paired
    const float* lc = l + r;
    for (int x = 0; x < W; ++x) o[x] = k[r] * lc[x];
    for (int t = 0; t < r; ++t) {
      const float kt = k[t];
      const float *la = l + t, *lb = l + (taps - 1 - t);
      for (int x = 0; x < W; ++x) o[x] += kt * (la[x] + lb[x]);
    }
  }
  if (row_index_.size() != static_cast<std::size_t>(H) * taps) {
    row_index_.resize(static_cast<std::size_t>(H) * taps);
    for (int y = 0; y < H; ++y)
      for (int t = 0; t < taps; ++t)
        row_index_[static_cast<std::size_t>(y) * taps + t] =
            cv::borderInterpolate(y + t - r, H, cv::BORDER_REFLECT_101);
  }
  dst.create(H, W, CV_32F);
  for (int y = 0; y < H; ++y) {
    float* o = dst.ptr<float>(y);
    const int* ri = row_index_.data() + static_cast<std::size_t>(y) * taps;
    const float* rc = rows_.ptr<float>(ri[r]);
    for (int x = 0; x < W; ++x) o[x] = k[r] * rc[x];
    for (int t = 0; t < r; ++t) {
      const float kt = k[t];
      const float *ra = rows_.ptr<float>(ri[t]), *rb = rows_.ptr<float>(ri[taps - 1 - t]);
      for (int x = 0; x < W; ++x) o[x] += kt * (ra[x] + rb[x]);
    }
  }
}

void sobel3_32f(const cv::Mat& src, cv::Mat& gx, cv::Mat& gy, float scale) {
  if (src.empty() || src.type() != CV_32FC1)
    throw std::invalid_argument("sobel3_32f: src must be a non-empty CV_32FC1 image");
  const int W = src.cols, H = src.rows;
  gx.create(H, W, CV_32F);
  gy.create(H, W, CV_32F);
  for (int y = 0; y < H; ++y) {
    const float* a = src.ptr<float>(cv::borderInterpolate(y - 1, H, cv::BORDER_REFLECT_101));
    const float* b = src.ptr<float>(y);
    const float* c = src.ptr<float>(cv::borderInterpolate(y + 1, H, cv::BORDER_REFLECT_101));
    float* ox = gx.ptr<float>(y);
    float* oy = gy.ptr<float>(y);
    for (int x = 0; x < W; ++x) {
      const int l = x > 0 ? x - 1 : cv::borderInterpolate(-1, W, cv::BORDER_REFLECT_101);
      const int rr = x < W - 1 ? x + 1 : cv::borderInterpolate(W, W, cv::BORDER_REFLECT_101);
      // [-1 0 1] across, [1 2 1] along; and the transpose.
      ox[x] = scale * ((a[rr] - a[l]) + 2.f * (b[rr] - b[l]) + (c[rr] - c[l]));
      oy[x] = scale * ((c[l] - a[l]) + 2.f * (c[x] - a[x]) + (c[rr] - a[rr]));
    }
  }
}

// ---- GuidedFilter ----

GuidedFilter::GuidedFilter(int radius_px, double eps) : r_(radius_px), eps_(eps) {
  if (radius_px < 1) throw std::invalid_argument("GuidedFilter: radius must be >= 1 px");
  if (!std::isfinite(eps) || eps <= 0.0) throw std::invalid_argument("GuidedFilter: eps must be > 0");
}

void GuidedFilter::box_mean(const cv::Mat& in, cv::Mat& out) {
  const int W = in.cols, H = in.rows, r = r_;
  rows_.create(H, W, CV_32F);
  out.create(H, W, CV_32F);
  inv_count_x_.resize(static_cast<std::size_t>(W));  // no-op once sized
  column_.resize(static_cast<std::size_t>(W));
  float* ix = inv_count_x_.data();
  for (int x = 0; x < W; ++x) ix[x] = 1.0f / static_cast<float>(std::min(x + r, W - 1) - std::max(x - r, 0) + 1);
  // Along the rows: a running window sum, one pixel in and one out per step (float: a window
  // holds at most 2 r + 1 values of a map in [0, 1]; the rounding stays near 1e-6 of it).
  // Four rows at a time: four independent sums keep the adder busy where one running sum would
  // wait on itself.
  constexpr int kRows = 4;
  for (int y0 = 0; y0 < H; y0 += kRows) {
    const int rows = std::min(kRows, H - y0);
    const float* s[kRows];
    float* o[kRows];
    float sum[kRows] = {};
    for (int k = 0; k < kRows; ++k) {
      const int y = y0 + std::min(k, rows - 1);  // a short last group repeats its last row
      s[k] = in.ptr<float>(y);
      o[k] = rows_.ptr<float>(y);
    }
    for (int x = 0; x <= std::min(r, W - 1); ++x)
      for (int k = 0; k < kRows; ++k) sum[k] += s[k][x];
    for (int k = 0; k < kRows; ++k) o[k][0] = sum[k] * ix[0];
    for (int x = 1; x < W; ++x) {
      const bool enters = x + r < W, leaves = x - r - 1 >= 0;
      for (int k = 0; k < kRows; ++k) {
        if (enters) sum[k] += s[k][x + r];
        if (leaves) sum[k] -= s[k][x - r - 1];
        o[k][x] = sum[k] * ix[x];
      }
    }
  }
  // Down the columns: the same with a row of column sums (vectorised along the row).
  float* c = column_.data();
  std::fill(c, c + W, 0.f);
  for (int y = 0; y <= std::min(r, H - 1); ++y) {
    const float* p = rows_.ptr<float>(y);
    for (int x = 0; x < W; ++x) c[x] += p[x];
  }
  for (int y = 0; y < H; ++y) {
    if (y > 0 && y + r < H) {
      const float* p = rows_.ptr<float>(y + r);
      for (int x = 0; x < W; ++x) c[x] += p[x];
    }
    if (y > 0 && y - r - 1 >= 0) {
      const float* p = rows_.ptr<float>(y - r - 1);
      for (int x = 0; x < W; ++x) c[x] -= p[x];
    }
    const float inv = 1.0f / static_cast<float>(std::min(y + r, H - 1) - std::max(y - r, 0) + 1);
    float* o = out.ptr<float>(y);
    for (int x = 0; x < W; ++x) o[x] = c[x] * inv;
  }
}

void GuidedFilter::apply(const cv::Mat& guide, const cv::Mat& src, cv::Mat& dst, float lo, float hi) {
  if (src.empty() || src.type() != CV_32FC1)
    throw std::invalid_argument("GuidedFilter: src must be non-empty CV_32FC1");
  if (guide.size() != src.size() || (guide.type() != CV_8UC1 && guide.type() != CV_32FC1))
    throw std::invalid_argument("GuidedFilter: guide must be CV_8UC1 or CV_32FC1 of the source's size");
  const int W = src.cols, H = src.rows;
  guide_.create(H, W, CV_32F);
  ip_.create(H, W, CV_32F);
  ii_.create(H, W, CV_32F);
  for (int y = 0; y < H; ++y) {
    float* g = guide_.ptr<float>(y);
    if (guide.type() == CV_8UC1) {
      const uchar* q = guide.ptr<uchar>(y);
      for (int x = 0; x < W; ++x) g[x] = static_cast<float>(q[x]) * (1.0f / 255.0f);
    } else {
      std::copy(guide.ptr<float>(y), guide.ptr<float>(y) + W, g);
    }
    const float* p = src.ptr<float>(y);
    float *ip = ip_.ptr<float>(y), *ii = ii_.ptr<float>(y);
    for (int x = 0; x < W; ++x) {
      ip[x] = g[x] * p[x];
      ii[x] = g[x] * g[x];
    }
  }
  box_mean(guide_, mean_i_);
  box_mean(src, mean_p_);
  box_mean(ip_, mean_ip_);
  box_mean(ii_, mean_ii_);
  // a and b of each window, into ip_ and ii_ (their products are no longer needed)
  const auto eps = static_cast<float>(eps_);
  for (int y = 0; y < H; ++y) {
    const float *mi = mean_i_.ptr<float>(y), *mp = mean_p_.ptr<float>(y), *mip = mean_ip_.ptr<float>(y),
                *mii = mean_ii_.ptr<float>(y);
    float *a = ip_.ptr<float>(y), *b = ii_.ptr<float>(y);
    for (int x = 0; x < W; ++x) {
      const float var = std::max(mii[x] - mi[x] * mi[x], 0.0f);
      a[x] = (mip[x] - mi[x] * mp[x]) / (var + eps);
      b[x] = mp[x] - a[x] * mi[x];
    }
  }
  box_mean(ip_, mean_ip_);  // mean a
  box_mean(ii_, mean_ii_);  // mean b
  dst.create(H, W, CV_32F);
  for (int y = 0; y < H; ++y) {
    const float *g = guide_.ptr<float>(y), *ma = mean_ip_.ptr<float>(y), *mb = mean_ii_.ptr<float>(y);
    float* o = dst.ptr<float>(y);
    for (int x = 0; x < W; ++x) o[x] = std::min(std::max(ma[x] * g[x] + mb[x], lo), hi);
  }
}

}  // namespace regolith::saliency
