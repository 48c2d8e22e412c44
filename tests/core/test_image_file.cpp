// regolith/core/image_file.hpp: only known image signatures reach OpenCV's decoders (GDCM, tried
// on bytes nobody claims, aborts the process on some: tests/fuzz/corpus/pixel_convert/gdcm_abort).
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "regolith/core/image_file.hpp"
#include "temp_dir.hpp"

namespace fs = std::filesystem;

TEST(ImageFile, KnownSignaturesOnly) {
  for (const std::string ext : {".png", ".jpg", ".tiff", ".bmp", ".pgm"}) {
    std::vector<unsigned char> bytes;
    ASSERT_TRUE(cv::imencode(ext, cv::Mat(8, 8, CV_8UC1, cv::Scalar(77)), bytes)) << ext;
    EXPECT_TRUE(regolith::known_image_signature(bytes.data(), bytes.size())) << ext;
    const cv::Mat back = regolith::decode_image(bytes.data(), bytes.size(), cv::IMREAD_UNCHANGED);
    EXPECT_EQ(back.size(), cv::Size(8, 8)) << ext;
  }
  // A known signature with "DICM" at byte 128: OpenCV hands it to GDCM when the named format's
  // own decoder declines the header (tests/fuzz: a WebP with inconsistent chunk sizes, 2.7 GB).
  std::vector<unsigned char> webp_dicm;
  ASSERT_TRUE(cv::imencode(".png", cv::Mat(40, 40, CV_8UC1, cv::Scalar(3)), webp_dicm));
  std::memcpy(webp_dicm.data() + 128, "DICM", 4);
  std::string dicm_why;
  EXPECT_TRUE(regolith::decode_image(webp_dicm.data(), webp_dicm.size(), cv::IMREAD_UNCHANGED, &dicm_why).empty());
  EXPECT_EQ(dicm_why, "not an image regolith reads (it carries a DICOM signature at byte 128)");
  // JPEG's SOI without the following marker, a DICOM-ish or random header: never decoded
  const std::vector<unsigned char> bad = {0xFF, 0xD8, 0x17, 0x17, 0x17, 0x17, 0x17, 0x17};
  EXPECT_FALSE(regolith::known_image_signature(bad.data(), bad.size()));
  EXPECT_TRUE(regolith::decode_image(bad.data(), bad.size(), cv::IMREAD_UNCHANGED).empty());
  const regolith::testing::TempDir tmp("img");  // removed whatever the outcome
  const fs::path f = tmp / "img.dcm";
  std::ofstream(f, std::ios::binary) << std::string(128, '\0') << "DICM";
  EXPECT_TRUE(regolith::read_image_file(f.string(), cv::IMREAD_UNCHANGED).empty());
  EXPECT_TRUE(regolith::read_image_file((f.string() + ".missing"), cv::IMREAD_UNCHANGED).empty());
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
    const regolith::testing::TempDir tmp("img_cut");  // removed whatever the outcome
    const fs::path f = tmp / ("img_cut" + ext);
    std::ofstream(f, std::ios::binary)
        .write(reinterpret_cast<const char*>(cut.data()), static_cast<std::streamsize>(cut.size()));
    EXPECT_TRUE(regolith::read_image_file(f.string(), cv::IMREAD_UNCHANGED, &why).empty()) << ext;
    EXPECT_EQ(why, expect);
    std::ofstream(f, std::ios::binary)
        .write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
    EXPECT_EQ(regolith::read_image_file(f.string(), cv::IMREAD_UNCHANGED, &why).size(), img.size()) << ext;
  }
  std::string why;
  EXPECT_TRUE(regolith::read_image_file("/nonexistent/x.png", cv::IMREAD_UNCHANGED, &why).empty());
  EXPECT_EQ(why, "cannot open it");
  // A directory given where an image was meant (`regolith assess DIR`) is called one.
  const regolith::testing::TempDir dir("img_dir");
  EXPECT_TRUE(regolith::read_image_file(dir.str(), cv::IMREAD_UNCHANGED, &why).empty());
  EXPECT_EQ(why, "it is a directory, not an image file");
}

TEST(ImageFile, TheDeclaredSizeIsReadFromEveryFormatsHeader) {
  cv::Mat img(23, 37, CV_8UC3);
  cv::randu(img, 0, 255);
  for (const std::string ext : {".png", ".jpg", ".bmp", ".ppm", ".pgm", ".tiff", ".webp"}) {
    std::vector<unsigned char> bytes;
    ASSERT_TRUE(cv::imencode(ext, ext == ".pgm" ? img.col(0).clone().reshape(1, 23) : img, bytes)) << ext;
    const regolith::ImageExtent e = regolith::declared_image_extent(bytes.data(), bytes.size());
    EXPECT_EQ(e.width, ext == ".pgm" ? 3u : 37u) << ext;
    EXPECT_EQ(e.height, 23u) << ext;
  }
  // Lossless WebP (VP8L) and an uncompressed-header form too.
  std::vector<unsigned char> lossless;
  ASSERT_TRUE(cv::imencode(".webp", img, lossless, {cv::IMWRITE_WEBP_QUALITY, 101}));
  EXPECT_EQ(std::string(lossless.begin() + 12, lossless.begin() + 16), "VP8L");
  EXPECT_EQ(regolith::declared_image_extent(lossless.data(), lossless.size()).width, 37u);
  // Extended WebP (VP8X): the canvas size, 24 bits each, minus one; 31 bytes are not enough to
  // hold it (read under ASan: no byte past the end).
  std::vector<unsigned char> vp8x = {'R', 'I', 'F', 'F', 0, 0, 0, 0, 'W',  'E',  'B',  'P',  'V',  'P',  '8', 'X',
                                     10,  0,   0,   0,   0, 0, 0, 0, 0x1F, 0x4E, 0x00, 0x1F, 0x4E, 0x00, 0,   0};
  EXPECT_EQ(regolith::declared_image_extent(vp8x.data(), vp8x.size()).width, 20000u);
  EXPECT_EQ(regolith::declared_image_extent(vp8x.data(), vp8x.size()).height, 20000u);
  vp8x.resize(31);
  EXPECT_FALSE(regolith::declared_image_extent(vp8x.data(), vp8x.size()).known());
  // Headers cut before the size: unknown, the decoder judges.
  std::vector<unsigned char> png;
  ASSERT_TRUE(cv::imencode(".png", img, png));
  EXPECT_FALSE(regolith::declared_image_extent(png.data(), 20).known());
}

TEST(ImageFile, AnImageDeclaringMorePixelsThanTheBoundIsNotDecoded) {
  // A few kilobytes that declare 20000 x 20000 (a 389 KB PNG of zeros did: 400 MB of pixels and
  // gigabytes of working maps in `assess`): refused from the header, with the reason.
  cv::Mat img(60, 80, CV_8UC1, cv::Scalar(9));
  std::vector<unsigned char> png, jpg, bmp;
  ASSERT_TRUE(cv::imencode(".png", img, png));
  ASSERT_TRUE(cv::imencode(".jpg", img, jpg));
  ASSERT_TRUE(cv::imencode(".bmp", img, bmp));
  const auto put_be32 = [](std::vector<unsigned char>& b, std::size_t at, std::uint32_t v) {
    for (int k = 0; k < 4; ++k) b[at + static_cast<std::size_t>(k)] = static_cast<unsigned char>(v >> (24 - 8 * k));
  };
  put_be32(png, 16, 20000);  // IHDR width, height (the CRC no longer matches: never reached)
  put_be32(png, 20, 20000);
  for (std::size_t i = 2; i + 8 < jpg.size(); ++i)  // SOF0: FF C0 len(2) precision(1) height(2) width(2)
    if (jpg[i] == 0xFF && jpg[i + 1] == 0xC0) {
      jpg[i + 5] = jpg[i + 7] = 0xFF;
      jpg[i + 6] = jpg[i + 8] = 0xFF;
      break;
    }
  bmp[18] = 0x20, bmp[19] = 0x4E, bmp[20] = bmp[21] = 0;     // width 20000
  bmp[22] = 0xE0, bmp[23] = 0xB1, bmp[24] = bmp[25] = 0xFF;  // height -20000 (top-down)
  const std::string pnm = "P5\n# a comment\n20000 20000\n255\n" + std::string(64, '\0');
  const std::vector<unsigned char> pgm(pnm.begin(), pnm.end());
  const std::vector<unsigned char>* all[] = {&png, &jpg, &bmp, &pgm};
  for (const auto* b : all) {
    std::string why;
    EXPECT_TRUE(regolith::decode_image(b->data(), b->size(), cv::IMREAD_UNCHANGED, &why).empty());
    EXPECT_NE(why.find("pixels, more than regolith decodes in one image (67108864"), std::string::npos) << why;
    EXPECT_TRUE(why.find("20000 x 20000") != std::string::npos || why.find("65535 x 65535") != std::string::npos)
        << why;
  }
  // From a file, the same (it is read whole, then decoded from memory).
  const regolith::testing::TempDir tmp("img_big");  // removed whatever the outcome
  const fs::path f = tmp / "img_big.png";
  std::ofstream(f, std::ios::binary)
      .write(reinterpret_cast<const char*>(png.data()), static_cast<std::streamsize>(png.size()));
  std::string why;
  EXPECT_TRUE(regolith::read_image_file(f.string(), cv::IMREAD_GRAYSCALE, &why).empty());
  EXPECT_NE(why.find("it declares 20000 x 20000 pixels"), std::string::npos) << why;
  // Garbage between JPEG segments: libjpeg skips it with a warning and reads the frame header
  // after it, so the header check must too (tests/fuzz: 1328 bytes declaring 12112 x 14895
  // behind 30 stray bytes made a 541 MB allocation).
  std::vector<unsigned char> stray = jpg;
  for (std::size_t i = 2; i + 1 < stray.size(); ++i)
    if (stray[i] == 0xFF && stray[i + 1] == 0xC0) {
      stray.insert(stray.begin() + static_cast<std::ptrdiff_t>(i), 30, 0x4A);
      break;
    }
  EXPECT_EQ(regolith::declared_image_extent(stray.data(), stray.size()).width, 65535u);
  std::string stray_why;
  EXPECT_TRUE(regolith::decode_image(stray.data(), stray.size(), cv::IMREAD_UNCHANGED, &stray_why).empty());
  EXPECT_NE(stray_why.find("65535 x 65535 pixels"), std::string::npos) << stray_why;
  // A segment length below 2 (an APP0 of length 0): libjpeg skips nothing and scans on from after
  // the length, so the search must not stop there (tests/fuzz: 67 bytes, APP0 length 0 then a
  // frame header of 65455 x 12496 x 3, a 2.4 GB allocation).
  for (const unsigned zero_or_one : {0u, 1u}) {
    std::vector<unsigned char> app = jpg;
    const unsigned char app0[] = {0xFF, 0xE0, 0x00, static_cast<unsigned char>(zero_or_one), 0x4F, 0x4F};
    app.insert(app.begin() + 2, std::begin(app0), std::end(app0));
    EXPECT_EQ(regolith::declared_image_extent(app.data(), app.size()).width, 65535u) << zero_or_one;
    std::string app_why;
    EXPECT_TRUE(regolith::decode_image(app.data(), app.size(), cv::IMREAD_UNCHANGED, &app_why).empty());
    EXPECT_NE(app_why.find("65535 x 65535 pixels"), std::string::npos) << app_why;
  }
  // PNM numbers as OpenCV reads them: any non-digit ends a number and is consumed (tests/fuzz: 23
  // bytes, "P6\n2222\xff444444\xff44..." asked for a 2.96 GB allocation); a comment ends at '\r'.
  for (const std::string& head : {std::string("P6\n2222\xff"
                                              "444444\xff"
                                              "44ZO:1@\xa0"),
                                  std::string("P5 2222Z444444 255\n"), std::string("P5\n#c\r2222 444444\n255\n")}) {
    const std::vector<unsigned char> b(head.begin(), head.end());
    const regolith::ImageExtent e = regolith::declared_image_extent(b.data(), b.size());
    EXPECT_EQ(e.width, 2222u) << head;
    EXPECT_EQ(e.height, 444444u) << head;
    std::string pnm_why;
    EXPECT_TRUE(regolith::decode_image(b.data(), b.size(), cv::IMREAD_UNCHANGED, &pnm_why).empty());
    EXPECT_NE(pnm_why.find("2222 x 444444 pixels"), std::string::npos) << pnm_why;
  }
  // At the bound itself an image is decoded (8192 x 8192 would be; a small one certainly).
  const regolith::ImageExtent at{8192, 8192}, over{8193, 8192};
  EXPECT_FALSE(at.exceeds(regolith::kMaxImagePixels));
  EXPECT_TRUE(over.exceeds(regolith::kMaxImagePixels));
}

TEST(ImageFile, SixteenBitSamplesAreScaledByTheBitsTheImageUses) {
  // 12-bit data in a 16-bit container: 4095 -> 255, 2048 -> 128 (OpenCV's 8-bit read: 15 and 8).
  cv::Mat twelve(4, 4, CV_16U, cv::Scalar(2048));
  twelve.at<std::uint16_t>(0, 0) = 4095;
  cv::Mat g = regolith::to_8bit(twelve);
  ASSERT_EQ(g.type(), CV_8UC1);
  EXPECT_EQ(g.at<std::uint8_t>(0, 0), 255);
  EXPECT_EQ(g.at<std::uint8_t>(1, 1), 128);
  // 8-bit values in 16 bits are kept; a full 16-bit range maps 65535 to 255; channels stay.
  EXPECT_EQ(regolith::to_8bit(cv::Mat(2, 2, CV_16UC3, cv::Scalar(200, 100, 0))).at<cv::Vec3b>(1, 1),
            cv::Vec3b(200, 100, 0));
  EXPECT_EQ(regolith::to_8bit(cv::Mat(2, 2, CV_16U, cv::Scalar(65535))).at<std::uint8_t>(0, 0), 255);
  // 8-bit: the same pixels, not a copy.
  const cv::Mat eight(3, 3, CV_8U, cv::Scalar(7));
  EXPECT_EQ(regolith::to_8bit(eight).data, eight.data);
  // Float: 0..1 to 0..255; NaN, negative and infinite samples give defined pixels.
  cv::Mat f(1, 4, CV_32F);
  f.at<float>(0, 0) = 0.5f;
  f.at<float>(0, 1) = std::numeric_limits<float>::quiet_NaN();
  f.at<float>(0, 2) = -3.0f;
  f.at<float>(0, 3) = 1.0f;
  const cv::Mat f8 = regolith::to_8bit(f);
  EXPECT_EQ(f8.at<std::uint8_t>(0, 0), 128);
  EXPECT_EQ(f8.at<std::uint8_t>(0, 1), 0);
  EXPECT_EQ(f8.at<std::uint8_t>(0, 2), 0);
  EXPECT_EQ(f8.at<std::uint8_t>(0, 3), 255);
  f.at<float>(0, 3) = std::numeric_limits<float>::infinity();
  EXPECT_EQ(regolith::to_8bit(f).at<std::uint8_t>(0, 3), 255);
  // Signed samples: empty (callers refuse them by name).
  EXPECT_TRUE(regolith::to_8bit(cv::Mat(2, 2, CV_16S, cv::Scalar(5))).empty());

  // read_image_8bit: a 12-bit PNG read as grey and as colour.
  const regolith::testing::TempDir tmp("twelve");  // removed whatever the outcome
  const std::string path = tmp.file("twelve.png");
  ASSERT_TRUE(cv::imwrite(path, twelve));
  std::string why;
  const cv::Mat grey = regolith::read_image_8bit(path, cv::IMREAD_GRAYSCALE, &why);
  ASSERT_EQ(grey.type(), CV_8UC1) << why;
  EXPECT_EQ(grey.at<std::uint8_t>(0, 0), 255);
  EXPECT_EQ(grey.at<std::uint8_t>(3, 3), 128);
  const cv::Mat colour = regolith::read_image_8bit(path, cv::IMREAD_COLOR, &why);
  ASSERT_EQ(colour.type(), CV_8UC3) << why;
  EXPECT_EQ(colour.at<cv::Vec3b>(0, 0), cv::Vec3b(255, 255, 255));
}
