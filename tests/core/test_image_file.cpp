// regolith/core/image_file.hpp: only known image signatures reach OpenCV's decoders (GDCM, tried
// on bytes nobody claims, aborts the process on some: tests/fuzz/corpus/pixel_convert/gdcm_abort).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <unistd.h>

#include "regolith/core/image_file.hpp"

namespace fs = std::filesystem;

TEST(ImageFile, KnownSignaturesOnly) {
  for (const std::string ext : {".png", ".jpg", ".tiff", ".bmp", ".pgm"}) {
    std::vector<unsigned char> bytes;
    ASSERT_TRUE(cv::imencode(ext, cv::Mat(8, 8, CV_8UC1, cv::Scalar(77)), bytes)) << ext;
    EXPECT_TRUE(regolith::known_image_signature(bytes.data(), bytes.size())) << ext;
    const cv::Mat back = regolith::decode_image(bytes.data(), bytes.size(), cv::IMREAD_UNCHANGED);
    EXPECT_EQ(back.size(), cv::Size(8, 8)) << ext;
  }
  // JPEG's SOI without the following marker, a DICOM-ish or random header: never decoded
  const std::vector<unsigned char> bad = {0xFF, 0xD8, 0x17, 0x17, 0x17, 0x17, 0x17, 0x17};
  EXPECT_FALSE(regolith::known_image_signature(bad.data(), bad.size()));
  EXPECT_TRUE(regolith::decode_image(bad.data(), bad.size(), cv::IMREAD_UNCHANGED).empty());
  const fs::path f = fs::temp_directory_path() / ("regolith_img_" + std::to_string(::getpid()) + ".dcm");
  std::ofstream(f, std::ios::binary) << std::string(128, '\0') << "DICM";
  EXPECT_TRUE(regolith::read_image_file(f.string(), cv::IMREAD_UNCHANGED).empty());
  EXPECT_TRUE(regolith::read_image_file((f.string() + ".missing"), cv::IMREAD_UNCHANGED).empty());
  fs::remove(f);
}

TEST(ImageFile, TruncatedJpegAndPngAreRefusedWithTheReason) {
  // libjpeg / libpng decode a file cut short with only a warning (grey or missing rows): the
  // reader refuses it, from a file or from memory (a camera's MJPEG frame), and says why.
  cv::Mat img(60, 80, CV_8UC3);
  cv::randu(img, 0, 255);
  for (const std::string ext : {".jpg", ".png"}) {
    std::vector<unsigned char> bytes;
    ASSERT_TRUE(cv::imencode(ext, img, bytes));
    const std::vector<unsigned char> cut(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(bytes.size() / 2));
    const std::string expect = ext == ".jpg" ? "truncated JPEG (the data ends before its end-of-image marker)"
                                             : "truncated PNG (the data ends before its IEND chunk)";
    std::string why;
    EXPECT_TRUE(regolith::decode_image(cut.data(), cut.size(), cv::IMREAD_UNCHANGED, &why).empty()) << ext;
    EXPECT_EQ(why, expect);
    why.clear();
    EXPECT_EQ(regolith::decode_image(bytes.data(), bytes.size(), cv::IMREAD_UNCHANGED, &why).size(), img.size()) << ext;
    EXPECT_EQ(why, "");
    const fs::path f = fs::temp_directory_path() / ("regolith_img_cut_" + std::to_string(::getpid()) + ext);
    std::ofstream(f, std::ios::binary).write(reinterpret_cast<const char*>(cut.data()), static_cast<std::streamsize>(cut.size()));
    EXPECT_TRUE(regolith::read_image_file(f.string(), cv::IMREAD_UNCHANGED, &why).empty()) << ext;
    EXPECT_EQ(why, expect);
    std::ofstream(f, std::ios::binary).write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
    EXPECT_EQ(regolith::read_image_file(f.string(), cv::IMREAD_UNCHANGED, &why).size(), img.size()) << ext;
    fs::remove(f);
  }
  std::string why;
  EXPECT_TRUE(regolith::read_image_file("/nonexistent/x.png", cv::IMREAD_UNCHANGED, &why).empty());
  EXPECT_EQ(why, "cannot open it");
}
