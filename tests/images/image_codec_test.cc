// fleetmap_images (fleetmap/images/image_codec.h) against OpenCV's own codecs: every PNG layout
// OpenCV's encoder and libpng write, JPEG files, and the real EuRoC and KITTI images decode to
// the pixels cv::imdecode gives, in each mode; what EncodePng writes OpenCV reads back whole;
// cut, damaged and foreign bytes are refused, naming the file.
#include "fleetmap/images/image_codec.h"

#include <gtest/gtest.h>
#include <png.h>
#include <zlib.h>

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "euroc_test_data.h"
#include "expect_error.h"
#include "image_files.h"
#include "jpeg_test_file.h"
#include "kitti_test_data.h"

namespace fleetmap {
namespace {

namespace fs = std::filesystem;

struct Mode {
  ImagePixels ours;
  int opencv_flag;
  const char* name;
};
const Mode kModes[] = {{ImagePixels::kAsStored, cv::IMREAD_UNCHANGED, "as stored"},
                       {ImagePixels::kGray8, cv::IMREAD_GRAYSCALE, "grey"},
                       {ImagePixels::kBgr8, cv::IMREAD_COLOR, "BGR"}};

cv::Mat OpenCvDecode(const std::string& file, int flag) {
  return cv::imdecode(
      cv::Mat(1, static_cast<int>(file.size()), CV_8UC1, const_cast<char*>(file.data())), flag);
}

std::string OpenCvEncode(const std::string& ext, const cv::Mat& pixels,
                         const std::vector<int>& params = {}) {
  std::vector<unsigned char> file;
  EXPECT_TRUE(cv::imencode(ext, pixels, file, params));
  return std::string(file.begin(), file.end());
}

cv::Mat Noise(int rows, int cols, int type, std::uint64_t seed) {
  cv::Mat m(rows, cols, type);
  cv::RNG rng(seed);
  rng.fill(m, cv::RNG::UNIFORM, 0, CV_MAT_DEPTH(type) == CV_16U ? 65536 : 256);
  return m;
}

// In every mode, DecodeImage gives the type, size and pixels cv::imdecode gives.
void ExpectDecodesAsOpenCv(const std::string& file, const std::string& what) {
  for (const Mode& mode : kModes) {
    SCOPED_TRACE(what + ", " + mode.name);
    const cv::Mat theirs = OpenCvDecode(file, mode.opencv_flag);
    ASSERT_FALSE(theirs.empty());
    const cv::Mat ours = DecodeImage(file, mode.ours, what);
    ASSERT_EQ(ours.type(), theirs.type());
    ASSERT_EQ(ours.size(), theirs.size());
    EXPECT_EQ(cv::norm(ours, theirs, cv::NORM_INF), 0.0);
  }
}

TEST(ImageCodecTest, PngFilesOpenCvWritesDecodeToItsPixelsInEveryMode) {
  const int types[] = {CV_8UC1, CV_16UC1, CV_8UC3, CV_16UC3, CV_8UC4, CV_16UC4};
  std::uint64_t seed = 1;
  for (const int type : types) {
    ExpectDecodesAsOpenCv(OpenCvEncode(".png", Noise(23, 37, type, seed++)),
                          "type " + std::to_string(type));
  }
  // One bit a pixel (OpenCV's bilevel PNG).
  cv::Mat bits = Noise(19, 45, CV_8UC1, 99) > 127;
  ExpectDecodesAsOpenCv(OpenCvEncode(".png", bits, {cv::IMWRITE_PNG_BILEVEL, 1}), "bilevel");
}

// A PNG written by libpng itself in a layout OpenCV's encoder does not write: palettes, grey
// below 8 bits, grey with alpha, transparency chunks, Adam7 interlacing.
struct PngLayout {
  int bit_depth;
  int colour_type;
  bool interlaced;
  bool transparency;
  const char* name;
};

std::string WriteWithLibpng(const PngLayout& layout, std::uint64_t seed) {
  constexpr int kWidth = 29, kHeight = 17;
  std::string out;
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png_create_info_struct(png);
  png_set_write_fn(
      png, &out,
      [](png_structp p, png_bytep data, png_size_t n) {
        static_cast<std::string*>(png_get_io_ptr(p))->append(reinterpret_cast<char*>(data), n);
      },
      [](png_structp) {});
  png_set_IHDR(png, info, kWidth, kHeight, layout.bit_depth, layout.colour_type,
               layout.interlaced ? PNG_INTERLACE_ADAM7 : PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  cv::RNG rng(seed);
  std::vector<png_color> palette(std::size_t{1} << layout.bit_depth);
  std::vector<png_byte> alpha(palette.size());
  if (layout.colour_type == PNG_COLOR_TYPE_PALETTE) {
    for (std::size_t i = 0; i < palette.size(); ++i) {
      palette[i] = {static_cast<png_byte>(rng.uniform(0, 256)),
                    static_cast<png_byte>(rng.uniform(0, 256)),
                    static_cast<png_byte>(rng.uniform(0, 256))};
      alpha[i] = static_cast<png_byte>(rng.uniform(0, 256));
    }
    png_set_PLTE(png, info, palette.data(), static_cast<int>(palette.size()));
    if (layout.transparency)
      png_set_tRNS(png, info, alpha.data(), static_cast<int>(alpha.size()), nullptr);
  } else if (layout.transparency) {
    png_color_16 key{0, 200, 100, 50, 0};
    png_set_tRNS(png, info, nullptr, 0, &key);
  }
  png_write_info(png, info);
  const std::size_t row_bytes = png_get_rowbytes(png, info);
  std::vector<png_byte> pixels(row_bytes * kHeight);
  for (png_byte& b : pixels) b = static_cast<png_byte>(rng.uniform(0, 256));
  if (layout.transparency && layout.colour_type == PNG_COLOR_TYPE_RGB) {
    pixels[0] = 200, pixels[1] = 100, pixels[2] = 50;  // one pixel of the transparent colour
  }
  std::vector<png_bytep> rows(kHeight);
  for (int r = 0; r < kHeight; ++r) rows[r] = pixels.data() + row_bytes * r;
  png_write_image(png, rows.data());
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return out;
}

TEST(ImageCodecTest, PngLayoutsLibpngWritesDecodeToOpenCvsPixelsInEveryMode) {
  const PngLayout layouts[] = {
      {8, PNG_COLOR_TYPE_PALETTE, false, false, "palette"},
      {8, PNG_COLOR_TYPE_PALETTE, false, true, "palette with transparency"},
      {4, PNG_COLOR_TYPE_PALETTE, true, false, "4-bit palette, interlaced"},
      {1, PNG_COLOR_TYPE_GRAY, false, false, "1-bit grey"},
      {2, PNG_COLOR_TYPE_GRAY, false, false, "2-bit grey"},
      {4, PNG_COLOR_TYPE_GRAY, true, false, "4-bit grey, interlaced"},
      {8, PNG_COLOR_TYPE_GRAY_ALPHA, false, false, "grey with alpha"},
      {16, PNG_COLOR_TYPE_GRAY_ALPHA, true, false, "16-bit grey with alpha, interlaced"},
      {8, PNG_COLOR_TYPE_RGB, true, false, "RGB, interlaced"},
      {16, PNG_COLOR_TYPE_RGB, true, false, "16-bit RGB, interlaced"},
      {8, PNG_COLOR_TYPE_RGB, false, true, "RGB with a transparent colour"},
      {8, PNG_COLOR_TYPE_RGB_ALPHA, true, false, "RGBA, interlaced"},
  };
  std::uint64_t seed = 7;
  for (const PngLayout& layout : layouts) {
    ExpectDecodesAsOpenCv(WriteWithLibpng(layout, seed++), layout.name);
  }
}

TEST(ImageCodecTest, JpegFilesDecodeToOpenCvsPixelsInEveryMode) {
  cv::Mat smooth(40, 56, CV_8UC3);
  for (int r = 0; r < smooth.rows; ++r) {
    for (int c = 0; c < smooth.cols; ++c) {
      smooth.at<cv::Vec3b>(r, c) = cv::Vec3b(static_cast<uchar>(4 * r), static_cast<uchar>(4 * c),
                                             static_cast<uchar>(2 * (r + c)));
    }
  }
  ExpectDecodesAsOpenCv(OpenCvEncode(".jpg", Noise(33, 41, CV_8UC1, 3)), "grey noise (OpenCV)");
  ExpectDecodesAsOpenCv(OpenCvEncode(".jpg", smooth), "colour (OpenCV)");
  ExpectDecodesAsOpenCv(testing::EncodeJpegForTest(Noise(24, 30, CV_8UC3, 4), 80),
                        "colour noise (libjpeg)");
}

TEST(ImageCodecTest, WhatEncodePngWritesOpenCvReadsBackWhole) {
  const int types[] = {CV_8UC1, CV_16UC1, CV_8UC3, CV_16UC3, CV_8UC4, CV_16UC4};
  std::uint64_t seed = 11;
  for (const int type : types) {
    SCOPED_TRACE("type " + std::to_string(type));
    const cv::Mat pixels = Noise(31, 43, type, seed++);
    const std::string png = EncodePng(pixels);
    const cv::Mat back = OpenCvDecode(png, cv::IMREAD_UNCHANGED);
    ASSERT_EQ(back.type(), type);
    EXPECT_EQ(cv::norm(back, pixels, cv::NORM_INF), 0.0);
    EXPECT_EQ(EncodePng(pixels), png);  // the bytes depend only on the pixels
    // Compressed as OpenCV compresses: within a few per cent of its file.
    const double opencv_bytes = static_cast<double>(OpenCvEncode(".png", pixels).size());
    EXPECT_LT(static_cast<double>(png.size()), 1.05 * opencv_bytes);
  }
  // A region of a larger matrix: rows that are not contiguous.
  const cv::Mat big = Noise(50, 60, CV_8UC3, 5);
  const cv::Mat region = big(cv::Rect(7, 9, 21, 13));
  EXPECT_EQ(cv::norm(OpenCvDecode(EncodePng(region), cv::IMREAD_UNCHANGED), region, cv::NORM_INF),
            0.0);
}

TEST(ImageCodecTest, TheRealDatasetsImagesDecodeAsOpenCvDecodesThem) {
  FLEETMAP_REQUIRE_EUROC_SEQUENCE();
  testing::RequireKittiExcerpts();
  std::vector<fs::path> files;
  for (const char* camera : {"cam0", "cam1"}) {
    std::vector<fs::path> all;
    for (const auto& entry :
         fs::directory_iterator(testing::EurocSequenceDir() / camera / "data")) {
      all.push_back(entry.path());
    }
    std::sort(all.begin(), all.end());
    ASSERT_FALSE(all.empty());
    files.push_back(all.front());
  }
  for (const char* seq : {"seq1", "seq2"}) {
    for (const char* side : {"image_l", "image_r"}) {
      files.push_back(testing::KittiExcerptsDir() / seq / side / "000000.png");
    }
  }
  for (const fs::path& file : files) {
    ExpectDecodesAsOpenCv(testing::ReadFileBytes(file), file.string());
  }
}

TEST(ImageCodecTest, CutDamagedAndForeignBytesAreRefusedByName) {
  const std::string png = EncodePng(Noise(20, 30, CV_8UC3, 21));
  // Cut anywhere: the signature's end, the header, the pixels, the last chunk.
  for (std::size_t length : {std::size_t{8}, std::size_t{20}, std::size_t{40}, png.size() / 2,
                             png.size() - 13, png.size() - 1}) {
    SCOPED_TRACE("cut to " + std::to_string(length));
    ExpectError(
        ErrorCode::kCorrupt,
        [&] { DecodeImage(png.substr(0, length), ImagePixels::kAsStored, "cut.png"); }, "cut.png");
  }
  // A flipped byte in the pixels' chunk fails its CRC.
  const std::size_t idat = png.find("IDAT");
  ASSERT_NE(idat, std::string::npos);
  std::string flipped = png;
  flipped[idat + 10] = static_cast<char>(flipped[idat + 10] ^ 0x40);
  ExpectError(
      ErrorCode::kCorrupt, [&] { DecodeImage(flipped, ImagePixels::kGray8, "flipped.png"); },
      "flipped.png");
  // A JPEG cut in half: libjpeg would fill the rest with grey (and OpenCV return it).
  const std::string jpeg = OpenCvEncode(".jpg", Noise(64, 64, CV_8UC1, 22));
  ExpectError(
      ErrorCode::kCorrupt,
      [&] { DecodeImage(jpeg.substr(0, jpeg.size() / 2), ImagePixels::kGray8, "half.jpg"); },
      "half.jpg");
  ExpectError(
      ErrorCode::kCorrupt, [&] { DecodeImage("BM not an image", ImagePixels::kAsStored, "x.bmp"); },
      "neither a PNG nor a JPEG");
  ExpectError(
      ErrorCode::kCorrupt, [&] { DecodeImage("", ImagePixels::kAsStored, "empty"); }, "empty");
  // A header declaring 999,999 x 2,000 pixels, within libpng's limits and beyond OpenCV's (its
  // CRC made right): refused before any allocation.
  std::string wide = EncodePng(cv::Mat(1, 1, CV_8UC1, cv::Scalar(0)));
  const std::size_t ihdr = wide.find("IHDR");
  const char size[8] = {0, 0x0F, 0x42, 0x3F, 0, 0, 0x07, static_cast<char>(0xD0)};
  wide.replace(ihdr + 4, 8, size, 8);
  const std::uint32_t crc =
      static_cast<std::uint32_t>(crc32(0, reinterpret_cast<const Bytef*>(wide.data() + ihdr), 17));
  for (int i = 0; i < 4; ++i) wide[ihdr + 17 + i] = static_cast<char>(crc >> (24 - 8 * i));
  ExpectError(
      ErrorCode::kCorrupt, [&] { DecodeImage(wide, ImagePixels::kAsStored, "wide.png"); },
      "beyond");
  // CMYK JPEG files are not read; other matrices are not written.
  ExpectError(
      ErrorCode::kInvalidArgument,
      [&] {
        DecodeImage(testing::EncodeJpegForTest(Noise(8, 8, CV_8UC4, 23)), ImagePixels::kBgr8,
                    "cmyk.jpg");
      },
      "CMYK");
  ExpectError(
      ErrorCode::kInvalidArgument, [] { EncodePng(cv::Mat(2, 2, CV_32FC1)); }, "PNG");
  ExpectError(
      ErrorCode::kInvalidArgument, [] { EncodePng(cv::Mat()); }, "PNG");
}

}  // namespace
}  // namespace fleetmap
