// Bit-packed binary images: threshold, morphology by run-shaped elements, run-based labelling.
#include "regolith/saliency/bit_mask.hpp"

#include <algorithm>
#include <cstdlib>
#include <limits>
#include <stdexcept>

#include <opencv2/core/hal/intrin.hpp>

namespace regolith::saliency {

namespace {

constexpr std::uint64_t kOnes = ~std::uint64_t{0};

int trailing_zeros(std::uint64_t x) {
  return __builtin_ctzll(x);
}  // x != 0

// out[k] op= the bits of `lo` shifted down by r (0..63) bits: pixel x of the result is pixel x + r
// of `lo` (which has a readable word past its last).
template <bool kOr>
void combine_shifted(std::uint64_t* out, const std::uint64_t* lo, int r, int nw) {
  if (r == 0) {
    for (int k = 0; k < nw; ++k) out[k] = kOr ? (out[k] | lo[k]) : (out[k] & lo[k]);
    return;
  }
  const int l = 64 - r;
  for (int k = 0; k < nw; ++k) {
    const std::uint64_t v = (lo[k] >> r) | (lo[k + 1] << l);
    out[k] = kOr ? (out[k] | v) : (out[k] & v);
  }
}

}  // namespace

void BitMask::create(int rows, int cols) {
  if (rows <= 0 || cols <= 0) throw std::invalid_argument("BitMask: the image must be non-empty");
  rows_ = rows;
  cols_ = cols;
  words_ = (cols + 63) / 64;
  bits_.resize(static_cast<std::size_t>(rows) * static_cast<std::size_t>(words_));  // no-op once sized
}

std::uint64_t BitMask::last_word_mask() const {
  const int tail = cols_ % 64;
  return tail == 0 ? kOnes : (std::uint64_t{1} << tail) - 1;
}

void BitMask::threshold(const cv::Mat& image8u, int threshold) {
  if (image8u.type() != CV_8UC1 || image8u.empty())
    throw std::invalid_argument("BitMask::threshold: image must be non-empty CV_8UC1");
  create(image8u.rows, image8u.cols);
  const int w = cols_;
  const uchar t = cv::saturate_cast<uchar>(threshold);
  const bool none = threshold >= 255;  // no 8-bit value exceeds it
  const cv::v_uint8x16 tv = cv::v_setall_u8(t);
  for (int r = 0; r < rows_; ++r) {
    const uchar* p = image8u.ptr<uchar>(r);
    std::uint64_t* out = row(r);
    for (int k = 0; k < words_; ++k) {
      const int x0 = 64 * k;
      std::uint64_t word = 0;
      if (none) {
        // all clear
      } else if (threshold < 0) {
        word = kOnes;
      } else if (x0 + 64 <= w) {
        for (int q = 0; q < 4; ++q) {
          const cv::v_uint8x16 v = cv::v_load(p + x0 + 16 * q);
          word |= static_cast<std::uint64_t>(static_cast<unsigned>(cv::v_signmask(v > tv)) & 0xFFFFu) << (16 * q);
        }
      } else {
        for (int x = x0; x < w; ++x)
          if (p[x] > t) word |= std::uint64_t{1} << (x - x0);
      }
      out[k] = word;
    }
    out[words_ - 1] &= last_word_mask();
  }
}

void BitMask::unpack(cv::Mat& out) const {
  out.create(rows_, cols_, CV_8U);
  for (int r = 0; r < rows_; ++r) {
    const std::uint64_t* in = row(r);
    uchar* o = out.ptr<uchar>(r);
    for (int x = 0; x < cols_; ++x) o[x] = ((in[x >> 6] >> (x & 63)) & 1u) != 0 ? 255 : 0;
  }
}

BinaryMorphology::BinaryMorphology(const cv::Mat& kernel) {
  if (kernel.type() != CV_8UC1 || kernel.empty())
    throw std::invalid_argument("BinaryMorphology: kernel must be non-empty CV_8UC1");
  if (kernel.rows > 64) throw std::invalid_argument("BinaryMorphology: at most 64 kernel rows");
  const int ax = kernel.cols / 2;
  anchor_y_ = kernel.rows / 2;
  int reach = 0;
  for (int i = 0; i < kernel.rows; ++i) {
    const uchar* k = kernel.ptr<uchar>(i);
    int first = -1, last = -2;
    for (int j = 0; j < kernel.cols; ++j) {
      if (k[j] == 0) continue;
      if (first >= 0 && j != last + 1)
        throw std::invalid_argument("BinaryMorphology: every kernel row must be one run of members");
      if (first < 0) first = j;
      last = j;
    }
    if (first < 0) {
      row_run_.push_back(-1);
      continue;
    }
    const Run run{first - ax, last - ax};
    reach = std::max({reach, std::abs(run.first), std::abs(run.last)});
    auto it = std::find_if(distinct_.begin(), distinct_.end(),
                           [&](const Run& d) { return d.first == run.first && d.last == run.last; });
    row_run_.push_back(static_cast<int>(it - distinct_.begin()));
    if (it == distinct_.end()) distinct_.push_back(run);
  }
  pad_words_ = (reach + 63) / 64 + 1;
}

void BinaryMorphology::apply(const BitMask& src, BitMask& dst, bool dilate) {
  const int h = src.rows(), nw = src.words(), pw = pad_words_;
  const std::uint64_t border = dilate ? 0 : kOnes;  // pixels outside the image do not take part
  const std::uint64_t tail = src.last_word_mask();
  padded_.resize(static_cast<std::size_t>(nw + 2 * pw));
  along_.resize(distinct_.size() * static_cast<std::size_t>(h) * static_cast<std::size_t>(nw));
  std::fill(padded_.begin(), padded_.end(), border);
  auto along = [&](std::size_t d, int y) {
    return along_.data() +
           (d * static_cast<std::size_t>(h) + static_cast<std::size_t>(y)) * static_cast<std::size_t>(nw);
  };
  // Along each distinct run: out[x] = op over o in [first, last] of row[x + o], by word shifts.
  for (int y = 0; y < h; ++y) {
    const std::uint64_t* s = src.row(y);
    std::copy(s, s + nw, padded_.begin() + pw);
    padded_[static_cast<std::size_t>(pw + nw - 1)] = (s[nw - 1] & tail) | (border & ~tail);
    for (std::size_t d = 0; d < distinct_.size(); ++d) {
      std::uint64_t* out = along(d, y);
      std::fill(out, out + nw, border);
      for (int o = distinct_[d].first; o <= distinct_[d].last; ++o) {
        const int q = o >= 0 ? o / 64 : -((-o + 63) / 64);  // floor(o / 64)
        const int r = o - 64 * q;
        const std::uint64_t* lo = padded_.data() + pw + q;
        if (dilate)
          combine_shifted<true>(out, lo, r, nw);
        else
          combine_shifted<false>(out, lo, r, nw);
      }
    }
  }
  // Across the kernel's rows.
  dst.create(h, src.cols());
  for (int y = 0; y < h; ++y) {
    std::uint64_t* out = dst.row(y);
    std::fill(out, out + nw, border);
    for (std::size_t i = 0; i < row_run_.size(); ++i) {
      const int sy = y + static_cast<int>(i) - anchor_y_;
      if (row_run_[i] < 0 || sy < 0 || sy >= h) continue;
      const std::uint64_t* v = along(static_cast<std::size_t>(row_run_[i]), sy);
      if (dilate)
        for (int k = 0; k < nw; ++k) out[k] |= v[k];
      else
        for (int k = 0; k < nw; ++k) out[k] &= v[k];
    }
    out[nw - 1] &= tail;
  }
}

int RunComponents::find(int a) {
  while (parent_[static_cast<std::size_t>(a)] != a) {
    const int p = parent_[static_cast<std::size_t>(a)];
    parent_[static_cast<std::size_t>(a)] = parent_[static_cast<std::size_t>(p)];  // path halving
    a = p;
  }
  return a;
}

void RunComponents::reserve(int rows, int cols) {
  // At most one run per two pixels of a row.
  const std::size_t cap = static_cast<std::size_t>(rows) * static_cast<std::size_t>((cols + 1) / 2);
  if (spans_.capacity() < cap) {
    spans_.reserve(cap);
    parent_.resize(cap);
    key_.resize(cap);
    label_.resize(cap);
    order_.resize(cap);
    stats_.resize(cap);
  }
  if (row_start_.capacity() < static_cast<std::size_t>(rows) + 1)
    row_start_.reserve(static_cast<std::size_t>(rows) + 1);
}

int RunComponents::run(const BitMask& mask) {
  const int h = mask.rows(), w = mask.cols(), nw = mask.words();
  reserve(h, w);
  row_start_.resize(static_cast<std::size_t>(h) + 1);
  spans_.clear();
  // The runs of set bits of each row, and their unions with the runs of the row above that touch
  // them (8-connected: [b, e) touches [b', e') of the row above when b' <= e and b <= e').
  for (int y = 0; y < h; ++y) {
    row_start_[static_cast<std::size_t>(y)] = static_cast<int>(spans_.size());
    const std::uint64_t* bits = mask.row(y);
    bool open = false;
    int begin = 0;
    for (int k = 0; k < nw; ++k) {
      const std::uint64_t word = bits[k];
      int p = 0;
      while (p < 64) {
        const std::uint64_t m = (open ? ~word : word) >> p;
        if (m == 0) break;
        p += trailing_zeros(m);
        if (open) {
          spans_.push_back({y, begin, 64 * k + p});
        } else {
          begin = 64 * k + p;
        }
        open = !open;
      }
    }
    if (open) spans_.push_back({y, begin, w});
  }
  row_start_[static_cast<std::size_t>(h)] = static_cast<int>(spans_.size());
  const int n = static_cast<int>(spans_.size());
  for (int i = 0; i < n; ++i) parent_[static_cast<std::size_t>(i)] = i;
  for (int y = 1; y < h; ++y) {
    int j = row_start_[static_cast<std::size_t>(y) - 1];
    const int j_end = row_start_[static_cast<std::size_t>(y)];
    const int c_end = row_start_[static_cast<std::size_t>(y) + 1];
    for (int c = j_end; c < c_end; ++c) {
      const Span& cs = spans_[static_cast<std::size_t>(c)];
      while (j < j_end && spans_[static_cast<std::size_t>(j)].end < cs.begin) ++j;
      for (int t = j; t < j_end && spans_[static_cast<std::size_t>(t)].begin <= cs.end; ++t) {
        const int a = find(c), b = find(t);
        if (a == b) continue;
        // the earlier span is the root
        if (a < b)
          parent_[static_cast<std::size_t>(b)] = a;
        else
          parent_[static_cast<std::size_t>(a)] = b;
      }
    }
  }
  // Numbering as OpenCV's block-based labelling: by each component's first 2x2 block in
  // block-raster order; a run's first block is the one of its first pixel.
  const int nbx = (w + 1) / 2;
  int roots = 0;
  for (int i = 0; i < n; ++i) {
    const Span& s = spans_[static_cast<std::size_t>(i)];
    const int root = find(i);
    const int key = (s.row / 2) * nbx + s.begin / 2;
    if (root == i) {
      key_[static_cast<std::size_t>(i)] = key;
      order_[static_cast<std::size_t>(roots++)] = i;
    } else {
      key_[static_cast<std::size_t>(root)] = std::min(key_[static_cast<std::size_t>(root)], key);
    }
  }
  std::sort(order_.begin(), order_.begin() + roots,
            [this](int a, int b) { return key_[static_cast<std::size_t>(a)] < key_[static_cast<std::size_t>(b)]; });
  for (int k = 0; k < roots; ++k) {
    label_[static_cast<std::size_t>(order_[static_cast<std::size_t>(k)])] = k;
    stats_[static_cast<std::size_t>(k)] = {w, h, -1, -1, 0};  // min x, min y, max x, max y, area
  }
  for (int i = 0; i < n; ++i) {
    const Span& s = spans_[static_cast<std::size_t>(i)];
    auto& st = stats_[static_cast<std::size_t>(label_[static_cast<std::size_t>(find(i))])];
    st[0] = std::min(st[0], s.begin);
    st[1] = std::min(st[1], s.row);
    st[2] = std::max(st[2], s.end - 1);
    st[3] = s.row;
    st[4] += s.end - s.begin;
  }
  for (int k = 0; k < roots; ++k) {
    auto& st = stats_[static_cast<std::size_t>(k)];
    st[2] = st[2] - st[0] + 1;
    st[3] = st[3] - st[1] + 1;
  }
  return roots;
}

}  // namespace regolith::saliency
