#pragma once
// Binary images as bits (64 pixels per word) for the detector's post-processing: the threshold,
// the opening and closing with an elliptical element and the 8-connected components of a saliency
// map cost a few word operations per 64 pixels instead of one byte operation per pixel, with the
// results of cv::erode / cv::dilate / cv::connectedComponentsWithStats (tests/saliency compare
// them bit for bit).
// Buffers are sized on the first image of a given size; later calls allocate nothing.
#include <array>
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

namespace regolith::saliency {

/// A binary image, row r's pixel c at bit (c % 64) of word r * words() + c / 64. Bits past the
/// last column are 0.
class BitMask {
 public:
  /// bit := image8u(r, c) > threshold (CV_8UC1, non-empty).
  void threshold(const cv::Mat& image8u, int threshold);
  /// CV_8U, 255 where the bit is set.
  void unpack(cv::Mat& out) const;
  void create(int rows, int cols);
  int rows() const { return rows_; }
  int cols() const { return cols_; }
  int words() const { return words_; }
  std::uint64_t* row(int r) { return bits_.data() + static_cast<std::ptrdiff_t>(r) * words_; }
  const std::uint64_t* row(int r) const { return bits_.data() + static_cast<std::ptrdiff_t>(r) * words_; }
  /// The mask of the bits of the last word that are pixels.
  std::uint64_t last_word_mask() const;

 private:
  int rows_ = 0, cols_ = 0, words_ = 0;
  std::vector<std::uint64_t> bits_;
};

/// Erosion and dilation of a BitMask by a structuring element whose every row is one run of
/// members (ellipses, rectangles, crosses; anchor at the centre), as cv::erode / cv::dilate with
/// the default border: pixels outside the image do not take part.
class BinaryMorphology {
 public:
  /// Throws std::invalid_argument when `kernel` (CV_8UC1, non-empty) has a row that is not one
  /// run or more than 64 rows.
  explicit BinaryMorphology(const cv::Mat& kernel);
  void erode(const BitMask& src, BitMask& dst) { apply(src, dst, false); }
  void dilate(const BitMask& src, BitMask& dst) { apply(src, dst, true); }

 private:
  void apply(const BitMask& src, BitMask& dst, bool dilate);
  struct Run {
    int first, last;  // column offsets from the anchor, first <= last
  };
  std::vector<Run> distinct_;  // the kernel rows' distinct runs
  std::vector<int> row_run_;   // kernel row -> index into distinct_ (-1: an empty row)
  int anchor_y_ = 0, pad_words_ = 1;
  std::vector<std::uint64_t> padded_;  // one source row with pad_words_ border words each side
  std::vector<std::uint64_t> along_;   // per distinct run, per image row: the op along the run
};

/// 8-connected components of a BitMask with the statistics and the numbering of
/// cv::connectedComponentsWithStats(..., 8, CV_32S) (its label k >= 1 is component k - 1 here),
/// found from the runs of set bits along each row.
class RunComponents {
 public:
  /// Returns the number of components (the background not counted).
  int run(const BitMask& mask);
  /// Sizes the buffers for masks of up to rows x cols: run() on them allocates nothing.
  void reserve(int rows, int cols);
  /// Component `i` (0 .. run() - 1) in cv::ConnectedComponentsTypes order: left, top, width,
  /// height, area (px).
  const std::array<int, 5>& stats(int i) const { return stats_[static_cast<std::size_t>(i)]; }
  /// After run(): f(component, row, begin, end) for every run of set pixels [begin, end) of a row,
  /// rows in order.
  template <class F>
  void for_each_run(F&& f) {
    for (std::size_t i = 0; i < spans_.size(); ++i) {
      const Span& s = spans_[i];
      f(label_[static_cast<std::size_t>(find(static_cast<int>(i)))], s.row, s.begin, s.end);
    }
  }

 private:
  struct Span {
    int row, begin, end;  // pixels [begin, end) of the row
  };
  int find(int a);
  std::vector<Span> spans_;
  std::vector<int> row_start_;  // per image row + 1: index of its first span
  std::vector<int> parent_;     // span -> parent span (a root is its set's first span)
  std::vector<int> key_;        // root span -> the set's first 2x2 block in block-raster order
  std::vector<int> order_;      // roots in that order
  std::vector<int> label_;      // root span -> component index
  std::vector<std::array<int, 5>> stats_;
};

}  // namespace regolith::saliency
