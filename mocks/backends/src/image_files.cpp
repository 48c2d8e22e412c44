// Camera "image_files": a directory or glob of images served at a fixed rate.
#include <algorithm>
#include <cctype>
#include <filesystem>

#include <glob.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "backends_internal.hpp"
#include "common.hpp"
#include "regolith/core/image_file.hpp"

namespace regolith::mocks {
namespace {

namespace fs = std::filesystem;

bool is_image_name(const fs::path& p) {
  std::string ext = p.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  static const char* const kExt[] = {".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp", ".pgm"};
  return std::any_of(std::begin(kExt), std::end(kExt), [&](const char* e) { return ext == e; });
}

std::vector<std::string> list_images(Params& p, const std::string& path) {
  std::vector<std::string> files;
  std::error_code ec;
  if (path.find_first_of("*?[") != std::string::npos) {
    glob_t g{};
    const int rc = ::glob(path.c_str(), 0, nullptr, &g);
    if (rc == 0) {
      for (std::size_t i = 0; i < g.gl_pathc; ++i) {
        if (fs::is_regular_file(g.gl_pathv[i], ec)) files.emplace_back(g.gl_pathv[i]);
      }
    }
    globfree(&g);
    if (files.empty()) p.fail("path", "pattern '" + path + "' matches no image file");
  } else if (fs::is_directory(path, ec)) {
    for (const auto& e : fs::directory_iterator(path, ec)) {
      if (e.is_regular_file(ec) && is_image_name(e.path())) files.push_back(e.path().string());
    }
    if (files.empty())
      p.fail("path", "directory '" + path + "' contains no image (.png .jpg .jpeg .tif .tiff .bmp .pgm)");
  } else if (fs::is_regular_file(path, ec)) {
    files.push_back(path);
  } else {
    p.fail("path", "'" + path + "' is neither a directory, an image file nor a glob pattern that exists");
  }
  std::sort(files.begin(), files.end());  // by name (glob already sorts; directories do not)
  return files;
}

}  // namespace

std::unique_ptr<hal::Camera> make_image_files_camera(Params& p, const hal::DeviceContext& ctx) {
  const std::string raw_path =
      p.require<std::string>("path", {.doc = "directory of images, an image file or a glob such as frames/*.png"});
  const double rate = p.get<double>(
      "rate_hz", 10.0,
      {.unit = "Hz", .min = 0.0, .max = 10000.0, .min_exclusive = true, .doc = "frame rate of the simulated camera"});
  const bool loop = p.get<bool>("loop", true, {.doc = "start again after the last image (else the last image stays)"});
  const std::string fmt_name =
      p.get<std::string>("format", "mono8", {.choices = {"mono8", "bgr8"}, .doc = "output pixel format"});
  const int width = p.get<int>(
      "width", 0, {.unit = "px", .min = 0, .max = kMaxImageSidePx, .doc = "resize to this width (0 = keep)"});
  const int height = p.get<int>(
      "height", 0, {.unit = "px", .min = 0, .max = kMaxImageSidePx, .doc = "resize to this height (0 = keep)"});
  const int max_frames =
      p.get<int>("max_frames", 1000, {.min = 1, .max = 1000000, .doc = "preload at most this many images"});
  if ((width == 0) != (height == 0)) p.fail(width == 0 ? "width" : "height", "give both width and height, or neither");

  hal::CameraFormat fmt;
  fmt.format = hal::pixel_format_from_string(fmt_name);
  fmt.rate_hz = rate;
  const std::string path = hal::resolve_path(ctx, raw_path);
  std::vector<std::string> files = list_images(p, path);
  if (files.size() > static_cast<std::size_t>(max_frames)) files.resize(static_cast<std::size_t>(max_frames));

  std::vector<cv::Mat> images;
  images.reserve(files.size());
  const int flags = fmt.format == hal::PixelFormat::kMono8 ? cv::IMREAD_GRAYSCALE : cv::IMREAD_COLOR;
  for (const auto& f : files) {
    std::string why;
    cv::Mat img = regolith::read_image_8bit(f, flags, &why);
    if (img.empty()) p.fail("path", "cannot read image '" + f + "': " + why);
    if (width > 0) {
      if (img.cols != width || img.rows != height) {
        cv::Mat resized;
        cv::resize(img, resized, cv::Size(width, height), 0, 0, cv::INTER_AREA);
        img = resized;
      }
    } else if (!images.empty() && img.size() != images.front().size()) {
      p.fail("path", "image '" + f + "' is " + std::to_string(img.cols) + "x" + std::to_string(img.rows) + " but '" +
                         files.front() + "' is " + std::to_string(images.front().cols) + "x" +
                         std::to_string(images.front().rows) + " (set width/height to resize all images)");
    }
    if (!img.isContinuous()) img = img.clone();
    // Every image of the list stays in memory: bounded as the rendered cameras are.
    if (images.empty())
      detail::check_preload(p, "max_frames", files.size(), img.size(), static_cast<int>(img.elemSize()));
    images.push_back(img);
  }
  fmt.width = images.front().cols;
  fmt.height = images.front().rows;
  return std::make_unique<detail::PreloadedCamera>(ctx, fmt, std::move(images), loop);
}

}  // namespace regolith::mocks
