// Integration tests of the stereo-batch tool over temporary directories.
#include <gtest/gtest.h>

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>
#include <zlib.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "integration/hostile_files.h"
#include "integration/run_tool.h"
#include "io/atomic_file.h"
#include "io/image_io.h"
#include "io/json_io.h"
#include "util/testing.h"

namespace lunarnav {
namespace {
namespace fs = std::filesystem;
using testing::ForgePngSize;
using testing::RunTool;
using util::ScopedTempDir;
using util::TestDataPath;

const char* kStems[] = {"frame0000", "frame0001", "frame0002"};

// A copy of testdata/stereo_pairs (images only) in `dir`.
fs::path CopyPairs(const fs::path& dir) {
  const fs::path in = dir / "pairs";
  for (const char* side : {"left", "right"}) {
    fs::create_directories(in / side);
    for (const char* stem : kStems) {
      fs::copy_file(TestDataPath("stereo_pairs") / side / (std::string(stem) + ".png"),
                    in / side / (std::string(stem) + ".png"));
    }
  }
  return in;
}

// Both presets, the default (quality) named by omission.
TEST(StereoBatch, MatchesTheTestdataPairsAgainstTheirGroundTruth) {
  for (const std::string preset : {"quality", "paper"}) {
  SCOPED_TRACE(preset);
  ScopedTempDir tmp;
  const fs::path out = tmp.path() / "out";
  std::vector<std::string> args = {TestDataPath("stereo_pairs").string(), "-o", out.string(), "-q"};
  if (preset == "paper") args.insert(args.end(), {"--preset", "paper"});
  const auto run = RunTool("stereo-batch", args, tmp.path());
  ASSERT_EQ(run.exit_code, 0) << run.stderr_text;
  EXPECT_EQ(run.ErrorLines(), 0);
  for (const char* stem : kStems) {
    const cv::Mat d = io::ReadPfm(out / "disparity" / (std::string(stem) + ".pfm"));
    const cv::Mat truth16 = cv::imread(
        (TestDataPath("stereo_pairs") / "truth" / "disparity" / (std::string(stem) + ".png")).string(),
        cv::IMREAD_UNCHANGED);
    ASSERT_EQ(d.size(), truth16.size());
    std::vector<double> errors;
    for (int y = 0; y < d.rows; ++y) {
      for (int x = 0; x < d.cols; ++x) {
        const float v = d.at<float>(y, x);
        const int t = truth16.at<std::uint16_t>(y, x);
        if (!std::isfinite(v) || t == 0) continue;  // +inf = no disparity; 0 = no truth
        errors.push_back(std::abs(v - t / 256.0));
      }
    }
    ASSERT_GT(errors.size(), 150000u) << stem;  // most of the 640 x 480 image
    std::sort(errors.begin(), errors.end());
    EXPECT_LT(errors[errors.size() / 2], 0.1) << stem;
    // Gross errors (> 1 px) only at the boxes' edges: a small fraction.
    const auto gross = errors.end() - std::upper_bound(errors.begin(), errors.end(), 1.0);
    EXPECT_LT(gross, 0.03 * errors.size()) << stem;
    // The confidence and rejection maps have the image's size and the right types.
    const cv::Mat c = cv::imread((out / "confidence" / (std::string(stem) + ".tif")).string(), cv::IMREAD_UNCHANGED);
    EXPECT_EQ(c.type(), CV_32FC1);
    const cv::Mat r = cv::imread((out / "rejections" / (std::string(stem) + ".png")).string(), cv::IMREAD_UNCHANGED);
    EXPECT_EQ(r.type(), CV_8UC1);
    EXPECT_EQ(r.size(), d.size());
  }
  const nlohmann::json summary = io::ReadJson(out / "summary.json");
  EXPECT_EQ(summary["counts"]["pairs_ok"], 3);
  EXPECT_EQ(summary["counts"]["pairs_failed"], 0);
  EXPECT_EQ(summary["options"]["preset"], preset);
  EXPECT_EQ(summary["options"]["half_window_px"],
            preset == "paper" ? nlohmann::json({25, 17}) : nlohmann::json({3, 3}));
  EXPECT_EQ(summary["options"]["aggregation"], preset == "paper" ? "window" : "semi_global");
  EXPECT_FALSE(fs::exists(out / "preview"));  // only on request
  EXPECT_EQ(summary["pairs"].size(), 3u);
  }
}

// A 12-bit camera's pair in 16-bit PNGs whose sBIT chunk says 12: the grey-level thresholds
// follow the true depth, so the pair matches like its 8-bit version (the paper's sigma_min = 2
// matters here); read as 16 significant bits the dim frame would be taken for a blank one.
TEST(StereoBatch, TwelveBitPngPairUsesItsTrueBitDepth) {
  ScopedTempDir tmp;
  const fs::path eight = tmp.path() / "eight", twelve = tmp.path() / "twelve";
  for (const char* side : {"left", "right"}) {
    fs::create_directories(eight / side);
    fs::create_directories(twelve / side);
    const cv::Mat image = cv::imread((TestDataPath("stereo_pairs") / side / "frame0000.png").string(),
                                     cv::IMREAD_GRAYSCALE);
    cv::Mat deep;
    image.convertTo(deep, CV_16U, 4095.0 / 255.0 / 4.0);  // a dim 12-bit exposure: 0..1023 of 4095
    cv::Mat back;
    deep.convertTo(back, CV_8U, 255.0 / 4095.0);
    io::WriteImageAtomic(eight / side / "p.png", back);
    io::WriteImageAtomic(twelve / side / "p.png", deep, 12);
  }
  auto accepted = [&](const fs::path& in, const std::string& name, std::vector<std::string> extra) {
    std::vector<std::string> args = {in.string(), "-o", (tmp.path() / name).string(), "-q", "--preset", "paper"};
    args.insert(args.end(), extra.begin(), extra.end());
    const auto run = RunTool("stereo-batch", args, tmp.path());
    EXPECT_EQ(run.exit_code, 0) << run.stderr_text;
    return io::ReadJson(tmp.path() / name / "disparity" / "p.json")["result"];
  };
  const nlohmann::json r8 = accepted(eight, "out8", {});
  const nlohmann::json r12 = accepted(twelve, "out12", {"--preview"});
  const cv::Mat preview = cv::imread((tmp.path() / "out12" / "preview" / "p.png").string(), cv::IMREAD_UNCHANGED);
  EXPECT_EQ(preview.type(), CV_8UC3);
  EXPECT_EQ(preview.cols, 640);
  EXPECT_GT(preview.rows, 480);  // the image and its legend
  EXPECT_EQ(r12["bit_depth"], 12);
  EXPECT_EQ(r12["bit_depth_source"], "PNG sBIT");
  const double a8 = r8["pixels_accepted"], a12 = r12["pixels_accepted"];
  EXPECT_GT(a8, 100000);
  EXPECT_NEAR(a12, a8, 0.02 * a8);
  const auto as16 = RunTool("stereo-batch", {twelve.string(), "-o", (tmp.path() / "out16").string(), "-q",
                                             "--preset", "paper", "--bit-depth", "16"},
                            tmp.path());
  EXPECT_EQ(as16.exit_code, 4);
  EXPECT_NE(as16.stderr_text.find("blank frame"), std::string::npos) << as16.stderr_text;
}

// The same camera without an sBIT chunk, as most machine-vision and planetary cameras write
// 12-bit data: the depth is told from the data (values up to 4095, a camera's noise at 12
// bits), and the disparities are those of --bit-depth 12, byte for byte. A dark 16-bit
// exposure of the same scene with a 16-bit camera's noise (values under 4096) stays 16. An
// 8-bit pair is untouched.
TEST(StereoBatch, TwelveBitPairWithoutSbitIsToldFromItsData) {
  ScopedTempDir tmp;
  const fs::path twelve = tmp.path() / "twelve", dark = tmp.path() / "dark";
  cv::RNG rng(3);
  for (const char* side : {"left", "right"}) {
    fs::create_directories(twelve / side);
    fs::create_directories(dark / side);
    const cv::Mat image = cv::imread((TestDataPath("stereo_pairs") / side / "frame0000.png").string(),
                                     cv::IMREAD_GRAYSCALE);
    cv::Mat deep, noise(image.size(), CV_32F), dim;
    image.convertTo(deep, CV_16U, 4095.0 / 255.0);  // 0..4095, no sBIT
    io::WriteImageAtomic(twelve / side / "p.png", deep);
    rng.fill(noise, cv::RNG::NORMAL, 0.0, 150.0);  // a 16-bit sensor's noise
    image.convertTo(dim, CV_32F, 3000.0 / 255.0 * 0.8);
    cv::Mat(cv::max(dim + noise, 0.0)).convertTo(dim, CV_16U);
    io::WriteImageAtomic(dark / side / "p.png", dim);
  }
  auto run = [&](const fs::path& in, const std::string& name, std::vector<std::string> extra,
                 const std::string& stem = "p") {
    std::vector<std::string> args = {in.string(), "-o", (tmp.path() / name).string(), "-q"};
    args.insert(args.end(), extra.begin(), extra.end());
    const auto result = RunTool("stereo-batch", args, tmp.path());
    EXPECT_EQ(result.exit_code, 0) << result.stderr_text;
    return io::ReadJson(tmp.path() / name / "disparity" / (stem + ".json"))["result"];
  };
  for (const char* preset : {"quality", "paper"}) {
    const std::string p = preset;
    const nlohmann::json told = run(twelve, "told-" + p, {"--preset", p});
    const nlohmann::json given = run(twelve, "given-" + p, {"--preset", p, "--bit-depth", "12"});
    EXPECT_EQ(told["bit_depth"], 12) << p;
    EXPECT_EQ(told["bit_depth_source"].get<std::string>().rfind("data (no sBIT)", 0), 0u) << told["bit_depth_source"];
    EXPECT_GT(told["pixels_accepted"].get<double>(), 0.3 * told["pixels_evaluated"].get<double>()) << p;
    EXPECT_EQ(testing::ReadFileBytes(tmp.path() / ("told-" + p) / "disparity" / "p.pfm"),
              testing::ReadFileBytes(tmp.path() / ("given-" + p) / "disparity" / "p.pfm"))
        << p;
  }
  // (At 16 bits its contrast is under the blank-frame check's one level of 8 bits: the check is
  // off here to read the depth in the sidecar.)
  const nlohmann::json dark_result = run(dark, "dark", {"--blank-sigma", "0"});
  EXPECT_EQ(dark_result["bit_depth"], 16);
  EXPECT_NE(dark_result["bit_depth_source"].get<std::string>().find("dark 16-bit image"), std::string::npos)
      << dark_result["bit_depth_source"];
  const nlohmann::json eight = run(TestDataPath("stereo_pairs"), "eight", {"--disparity", "0:63"}, "frame0000");
  EXPECT_EQ(eight["bit_depth"], 8);
  EXPECT_EQ(eight["bit_depth_source"], "image type");
  // One batch, two depths: a warning naming both.
  for (const char* side : {"left", "right"}) fs::copy_file(dark / side / "p.png", twelve / side / "q.png");
  const auto mixed = RunTool("stereo-batch", {twelve.string(), "-o", (tmp.path() / "mixed").string(), "--blank-sigma", "0"},
                             tmp.path());
  EXPECT_EQ(mixed.exit_code, 0) << mixed.stderr_text;
  EXPECT_NE(mixed.stderr_text.find("different depths: 12 bits (1 pair, e.g. p), 16 bits (1 pair, e.g. q)"),
            std::string::npos)
      << mixed.stderr_text;
  EXPECT_EQ(io::ReadJson(tmp.path() / "mixed" / "summary.json")["bit_depths"], nlohmann::json({{"12", 1}, {"16", 1}}));
}

// A change detector, not a property (the properties, against the testdata's true disparities,
// are MatchesTheTestdataPairsAgainstTheirGroundTruth's for both presets): the paper preset with
// the border rule (which the paper does not have) off gives the same disparity, confidence and
// rejection maps, bit for bit, as when their CRC-32 was recorded (after the median filter's
// neighbour count was corrected: filter 4 had missed the accepted neighbours whose own
// neighbourhood was fully accepted, and rejected some matches as isolated that are not). A
// change to the paper's matcher that is meant shows here and gets a new CRC with its reason.
// Then a property: with the rule (run after the median), the maps differ only at the pixels it
// rejects, and no pixel whose true match lies beyond the left image's edge (right reference:
// x + d > width - 1) is accepted.
TEST(StereoBatch, ChangeDetectorPaperPresetMapsBitForBitAndTheBorderRuleRejectsOnlyBeyondTheEdge) {
  ScopedTempDir tmp;
  const fs::path out = tmp.path() / "out";
  const auto run = RunTool("stereo-batch", {TestDataPath("stereo_pairs").string(), "-o", out.string(), "-q",
                                            "--preset", "paper", "--border-tolerance", "-1"},
                           tmp.path());
  ASSERT_EQ(run.exit_code, 0) << run.stderr_text;
  uLong crc = crc32(0L, Z_NULL, 0);
  for (const char* stem : kStems) {
    const cv::Mat maps[3] = {
        io::ReadPfm(out / "disparity" / (std::string(stem) + ".pfm")),
        cv::imread((out / "confidence" / (std::string(stem) + ".tif")).string(), cv::IMREAD_UNCHANGED),
        cv::imread((out / "rejections" / (std::string(stem) + ".png")).string(), cv::IMREAD_UNCHANGED)};
    for (const cv::Mat& m : maps) {
      ASSERT_TRUE(m.isContinuous());
      crc = crc32(crc, m.data, static_cast<uInt>(m.total() * m.elemSize()));
    }
  }
  EXPECT_EQ(crc, 0xc92362c9uL) << std::hex << crc;

  const fs::path ruled = tmp.path() / "ruled";
  const auto with_rule = RunTool("stereo-batch", {TestDataPath("stereo_pairs").string(), "-o", ruled.string(), "-q",
                                                  "--preset", "paper"},
                                 tmp.path());
  ASSERT_EQ(with_rule.exit_code, 0) << with_rule.stderr_text;
  int changed_elsewhere = 0, beyond = 0, beyond_accepted = 0;
  for (const char* stem : kStems) {
    const cv::Mat off = io::ReadPfm(out / "disparity" / (std::string(stem) + ".pfm"));
    const cv::Mat on = io::ReadPfm(ruled / "disparity" / (std::string(stem) + ".pfm"));
    const cv::Mat codes = cv::imread((ruled / "rejections" / (std::string(stem) + ".png")).string(), cv::IMREAD_UNCHANGED);
    const cv::Mat truth = cv::imread(
        (TestDataPath("stereo_pairs") / "truth" / "disparity" / (std::string(stem) + ".png")).string(),
        cv::IMREAD_UNCHANGED);
    ASSERT_EQ(truth.size(), on.size());
    const cv::Mat rule = codes == 10;  // beyond_border (docs/formats.md)
    for (int y = 0; y < off.rows; ++y) {
      for (int x = 0; x < off.cols; ++x) {
        const float a = off.at<float>(y, x), b = on.at<float>(y, x);
        const bool same = (std::isnan(a) && std::isnan(b)) || a == b;
        changed_elsewhere += !same && rule.at<std::uint8_t>(y, x) == 0;
        const std::uint16_t t = truth.at<std::uint16_t>(y, x);
        if (t > 0 && x + t / 256.0 > off.cols - 1) {  // KITTI's 16-bit scale; 0 = no truth
          ++beyond;
          beyond_accepted += std::isfinite(b);
        }
      }
    }
  }
  EXPECT_EQ(changed_elsewhere, 0);
  EXPECT_GT(beyond, 1000);
  EXPECT_EQ(beyond_accepted, 0);
}

// Headers claiming a million by a million pixels, or none: those pairs fail with one line
// naming the file and the claimed size, before anything is allocated; the others run.
TEST(StereoBatch, RefusesImagesLargerThanTheLimitFromTheirHeader) {
  ScopedTempDir tmp;
  const fs::path in = CopyPairs(tmp.path());
  ForgePngSize(in / "left" / "frame0001.png", 1000000, 1000000);
  ForgePngSize(in / "right" / "frame0002.png", 0, 0);
  const fs::path out = tmp.path() / "out";
  const auto run = RunTool("stereo-batch", {in.string(), "-o", out.string(), "-q", "--preset", "paper"}, tmp.path());
  EXPECT_EQ(run.exit_code, 4) << run.stderr_text;
  EXPECT_EQ(run.ErrorLines(), 2) << run.stderr_text;
  EXPECT_NE(run.stderr_text.find("frame0001.png: the header claims 1000000 x 1000000 pixels"), std::string::npos)
      << run.stderr_text;
  EXPECT_NE(run.stderr_text.find("frame0002.png: invalid PNG header (0 x 0 pixels)"), std::string::npos)
      << run.stderr_text;
  EXPECT_LT(run.stderr_text.size(), 1000u);
  EXPECT_TRUE(fs::exists(out / "disparity" / "frame0000.pfm"));
  // A smaller limit refuses the good pairs too, by name.
  const auto small = RunTool("stereo-batch", {in.string(), "-o", (tmp.path() / "small").string(), "-q",
                                              "--preset", "paper", "--max-pixels", "1000"},
                             tmp.path());
  EXPECT_EQ(small.exit_code, 4);
  EXPECT_NE(small.stderr_text.find("frame0000.png: the header claims 640 x 480 pixels"), std::string::npos)
      << small.stderr_text;
  // A size within the limit that the data cannot fill: libpng's reason in the one error line,
  // nothing printed by the library itself.
  ForgePngSize(in / "left" / "frame0000.png", 1000, 1000);
  const auto short_data =
      RunTool("stereo-batch", {in.string(), "-o", (tmp.path() / "short").string(), "-q", "--preset", "paper"},
              tmp.path());
  EXPECT_EQ(short_data.exit_code, 4);
  EXPECT_EQ(short_data.ErrorLines(), 3) << short_data.stderr_text;
  EXPECT_EQ(short_data.stderr_text.find("libpng"), std::string::npos) << short_data.stderr_text;
  EXPECT_NE(short_data.stderr_text.find("frame0000.png: truncated or corrupt image ("), std::string::npos)
      << short_data.stderr_text;
}

// Links that loop (two pointing at each other, one at itself) are those pairs' problems; the
// listing and the other pairs go on.
TEST(StereoBatch, LoopingLinksFailTheirPairsOnly) {
  ScopedTempDir tmp;
  const fs::path in = CopyPairs(tmp.path());
  fs::create_symlink(in / "left" / "b.png", in / "left" / "a.png");
  fs::create_symlink(in / "left" / "a.png", in / "left" / "b.png");
  fs::create_symlink(in / "right" / "c.png", in / "right" / "c.png");
  for (const char* stem : {"a", "b"}) fs::copy_file(in / "right" / "frame0000.png", in / "right" / (std::string(stem) + ".png"));
  fs::copy_file(in / "left" / "frame0000.png", in / "left" / "c.png");
  const fs::path out = tmp.path() / "out";
  const auto run = RunTool("stereo-batch", {in.string(), "-o", out.string(), "-q", "--preset", "paper"}, tmp.path());
  EXPECT_EQ(run.exit_code, 4) << run.stderr_text;
  EXPECT_EQ(run.ErrorLines(), 3) << run.stderr_text;
  EXPECT_NE(run.stderr_text.find("a.png: unusable symbolic link (Too many levels of symbolic links)"),
            std::string::npos) << run.stderr_text;
  for (const char* stem : kStems) EXPECT_TRUE(fs::exists(out / "disparity" / (std::string(stem) + ".pfm"))) << stem;
}

TEST(StereoBatch, ReportsAndSkipsBadPairs) {
  ScopedTempDir tmp;
  const fs::path in = CopyPairs(tmp.path());
  // frame0001: truncated right image.
  const std::string bytes = testing::ReadFileBytes(in / "right" / "frame0001.png");
  std::ofstream(in / "right" / "frame0001.png", std::ios::binary | std::ios::trunc)
      .write(bytes.data(), static_cast<std::streamsize>(bytes.size() / 2));
  // frame0002: the left image is smaller.
  cv::Mat small = cv::imread((in / "left" / "frame0002.png").string(), cv::IMREAD_GRAYSCALE);
  cv::imwrite((in / "left" / "frame0002.png").string(), small(cv::Rect(0, 0, 320, 240)));
  // cable: blank left frame; sun: saturated right frame; lonely: no right partner.
  cv::imwrite((in / "left" / "cable.png").string(), cv::Mat(480, 640, CV_8UC1, cv::Scalar(3)));
  fs::copy_file(in / "right" / "frame0000.png", in / "right" / "cable.png");
  fs::copy_file(in / "left" / "frame0000.png", in / "left" / "sun.png");
  cv::imwrite((in / "right" / "sun.png").string(), cv::Mat(480, 640, CV_8UC1, cv::Scalar(255)));
  fs::copy_file(in / "left" / "frame0000.png", in / "left" / "lonely.png");
  std::ofstream(in / "left" / "notes.txt") << "not an image";

  const fs::path out = tmp.path() / "out";
  const auto run = RunTool("stereo-batch", {in.string(), "-o", out.string(), "--window", "7x5"}, tmp.path());
  EXPECT_EQ(run.exit_code, 4) << run.stderr_text;
  EXPECT_EQ(run.ErrorLines(), 5) << run.stderr_text;
  for (const char* word : {"pair frame0001:", "truncated", "pair frame0002:", "differs", "pair cable:",
                           "blank", "pair sun:", "saturated", "pair lonely:", "missing"}) {
    EXPECT_NE(run.stderr_text.find(word), std::string::npos) << word << "\n" << run.stderr_text;
  }
  EXPECT_TRUE(fs::exists(out / "disparity" / "frame0000.pfm"));
  for (const char* bad : {"frame0001", "frame0002", "cable", "sun", "lonely"}) {
    EXPECT_FALSE(fs::exists(out / "disparity" / (std::string(bad) + ".pfm"))) << bad;
  }
  const nlohmann::json summary = io::ReadJson(out / "summary.json");
  EXPECT_EQ(summary["counts"]["pairs_ok"], 1);
  EXPECT_EQ(summary["counts"]["pairs_failed"], 5);
  EXPECT_EQ(summary["failed"].size(), 5u);
}

TEST(StereoBatch, ResumeSkipsCompletePairsAndRedoesIncompleteOnes) {
  ScopedTempDir tmp;
  const fs::path in = CopyPairs(tmp.path());
  const fs::path out = tmp.path() / "out";
  const std::vector<std::string> args = {in.string(), "-o", out.string(), "-q", "--window", "7x5"};
  ASSERT_EQ(RunTool("stereo-batch", args, tmp.path()).exit_code, 0);
  const auto before = fs::last_write_time(out / "disparity" / "frame0000.pfm");
  fs::remove(out / "disparity" / "frame0001.json");  // as if killed before the sidecar
  std::vector<std::string> resume = args;
  resume.push_back("--resume");
  ASSERT_EQ(RunTool("stereo-batch", resume, tmp.path()).exit_code, 0);
  EXPECT_EQ(fs::last_write_time(out / "disparity" / "frame0000.pfm"), before);
  const nlohmann::json summary = io::ReadJson(out / "summary.json");
  EXPECT_EQ(summary["counts"]["pairs_resumed"], 2);
  EXPECT_EQ(summary["counts"]["pairs_ok"], 1);
  EXPECT_TRUE(fs::exists(out / "disparity" / "frame0001.json"));
  // A map cut short by hand under its final name, its sidecar intact: that pair is redone.
  const fs::path cut = out / "disparity" / "frame0002.pfm";
  fs::resize_file(cut, fs::file_size(cut) / 2);
  ASSERT_EQ(RunTool("stereo-batch", resume, tmp.path()).exit_code, 0);
  EXPECT_EQ(io::ReadJson(out / "summary.json")["counts"]["pairs_resumed"], 2);
  EXPECT_EQ(io::ReadPfm(cut).rows, 480);
  // Other options: nothing is reused.
  resume.push_back("--c-min");
  resume.push_back("0.6");
  ASSERT_EQ(RunTool("stereo-batch", resume, tmp.path()).exit_code, 0);
  EXPECT_EQ(io::ReadJson(out / "summary.json")["counts"]["pairs_resumed"], 0);
}

TEST(StereoBatch, ShardsTogetherEqualTheSingleRun) {
  ScopedTempDir tmp;
  const fs::path in = CopyPairs(tmp.path());
  const fs::path single = tmp.path() / "single", sharded = tmp.path() / "sharded";
  ASSERT_EQ(RunTool("stereo-batch", {in.string(), "-o", single.string(), "-q", "--step", "3x2"}, tmp.path()).exit_code, 0);
  for (const char* shard : {"0/2", "1/2"}) {
    ASSERT_EQ(RunTool("stereo-batch", {in.string(), "-o", sharded.string(), "-q", "--step", "3x2", "--shard", shard, "-j", "1"},
                      tmp.path()).exit_code, 0);
  }
  for (const char* stem : kStems) {
    for (const auto& [dir, ext] : {std::pair{"disparity", ".pfm"}, {"confidence", ".tif"}, {"rejections", ".png"}}) {
      const fs::path a = single / dir / (std::string(stem) + ext), b = sharded / dir / (std::string(stem) + ext);
      EXPECT_EQ(testing::ReadFileBytes(a), testing::ReadFileBytes(b)) << a;
    }
  }
  EXPECT_EQ(io::ReadJson(sharded / "summary.shard-0-of-2.json")["counts"]["pairs_in_shard"], 2);
  EXPECT_EQ(io::ReadJson(sharded / "summary.shard-1-of-2.json")["counts"]["pairs_in_shard"], 1);
}

TEST(StereoBatch, AKilledRunLeavesNoHalfWrittenFile) {
  ScopedTempDir tmp;
  // Twelve pairs, so that the run is still writing when it is killed; a short search on a
  // coarse grid (the maps are still full size: the test is of the writing, not the matching;
  // under the sanitizers the full search took 4 min).
  const fs::path in = tmp.path() / "pairs";
  for (const char* side : {"left", "right"}) {
    fs::create_directories(in / side);
    for (int i = 0; i < 12; ++i) {
      fs::copy_file(TestDataPath("stereo_pairs") / side / (std::string(kStems[i % 3]) + ".png"),
                    in / side / ("p" + std::to_string(100 + i) + ".png"));
    }
  }
  const fs::path out = tmp.path() / "out";
  const std::string tool = util::ToolPath("stereo-batch").string();
  // Kill runs at growing delays (the machine may be slow or busy) until two were killed in
  // the middle of writing; a run that finished first is discarded and the delay shortened.
  int killed_mid_run = 0;
  int delay_ms = 60;
  for (int attempt = 0; attempt < 12 && killed_mid_run < 2; ++attempt) {
    const pid_t pid = fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      execl(tool.c_str(), tool.c_str(), in.c_str(), "-o", out.c_str(), "-q", "--resume", "-j", "1", "--disparity",
            "0:63", "--step", "4x4", static_cast<char*>(nullptr));
      _exit(127);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(delay_ms));
    kill(pid, SIGKILL);
    int status = 0;
    waitpid(pid, &status, 0);
    if (WIFEXITED(status)) {
      ASSERT_EQ(WEXITSTATUS(status), 0);
      fs::remove_all(out);
      delay_ms = std::max(20, delay_ms / 2);
      continue;
    }
    if (!fs::exists(out / "disparity") || fs::is_empty(out / "disparity")) {
      delay_ms *= 2;
      continue;
    }
    ++killed_mid_run;
    // Every file under its final name is complete.
    for (const auto& entry : fs::recursive_directory_iterator(out)) {
      if (!entry.is_regular_file() || io::IsTempFileName(entry.path())) continue;
      const std::string ext = entry.path().extension().string();
      if (ext == ".json") {
        EXPECT_NO_THROW(io::ReadJson(entry.path())) << entry.path();
      } else {
        const cv::Mat m = cv::imread(entry.path().string(), cv::IMREAD_UNCHANGED);
        EXPECT_EQ(m.size(), cv::Size(640, 480)) << entry.path();
      }
    }
  }
  EXPECT_GT(killed_mid_run, 0) << "no run was killed while writing its outputs";
  // A resumed run completes the set and clears the leftovers of the killed ones.
  ASSERT_EQ(RunTool("stereo-batch",
                    {in.string(), "-o", out.string(), "-q", "--resume", "--disparity", "0:63", "--step", "4x4"},
                    tmp.path())
                .exit_code,
            0);
  int files = 0;
  for (const auto& entry : fs::recursive_directory_iterator(out)) {
    if (!entry.is_regular_file()) continue;
    EXPECT_FALSE(io::IsTempFileName(entry.path())) << entry.path();
    ++files;
  }
  EXPECT_EQ(files, 12 * 4 + 1);  // 3 maps + sidecar per pair, and summary.json
}

TEST(StereoBatch, UsageAndInputErrorsHaveTheirExitCodes) {
  ScopedTempDir tmp;
  const fs::path in = CopyPairs(tmp.path());
  const std::string out = (tmp.path() / "out").string();
  EXPECT_EQ(RunTool("stereo-batch", {"--help"}, tmp.path()).exit_code, 0);
  EXPECT_EQ(RunTool("stereo-batch", {in.string()}, tmp.path()).exit_code, 2);  // no -o
  EXPECT_EQ(RunTool("stereo-batch", {in.string(), "-o", out, "--window", "0x0"}, tmp.path()).exit_code, 2);
  const auto rows = RunTool("stereo-batch", {in.string(), "-o", out, "--rows", "1000:2000"}, tmp.path());
  EXPECT_EQ(rows.exit_code, 2);
  EXPECT_NE(rows.stderr_text.find("outside the images' 480 rows"), std::string::npos) << rows.stderr_text;
  // Command-line errors are one line with the prefix every error has.
  for (const std::vector<std::string>& args : {std::vector<std::string>{}, {in.string(), "-o", "x", "--bogus"}}) {
    const auto bad = RunTool("stereo-batch", args, tmp.path());
    EXPECT_EQ(bad.exit_code, 2);
    EXPECT_EQ(bad.stderr_text.rfind("error: ", 0), 0u) << bad.stderr_text;
    EXPECT_EQ(std::count(bad.stderr_text.begin(), bad.stderr_text.end(), '\n'), 1) << bad.stderr_text;
  }
  EXPECT_EQ(RunTool("stereo-batch", {in.string(), "-o", out, "--window", "big"}, tmp.path()).exit_code, 2);
  EXPECT_EQ(RunTool("stereo-batch", {in.string(), "-o", out, "--shard", "2/2"}, tmp.path()).exit_code, 2);
  EXPECT_EQ(RunTool("stereo-batch", {in.string(), "-o", out, "--median", "4"}, tmp.path()).exit_code, 2);
  EXPECT_EQ(RunTool("stereo-batch", {in.string(), "-o", out, "--disparity", "50:10"}, tmp.path()).exit_code, 2);
  const auto missing = RunTool("stereo-batch", {(tmp.path() / "nowhere").string(), "-o", out}, tmp.path());
  EXPECT_EQ(missing.exit_code, 3);
  EXPECT_EQ(missing.ErrorLines(), 1);
  EXPECT_NE(missing.stderr_text.find("nowhere"), std::string::npos);
  std::ofstream(tmp.path() / "a_file") << "x";  // an output "directory" that is a file
  const auto bad_out = RunTool("stereo-batch", {in.string(), "-o", (tmp.path() / "a_file").string()}, tmp.path());
  EXPECT_EQ(bad_out.exit_code, 2);
  EXPECT_NE(bad_out.stderr_text.find("cannot create the output directory"), std::string::npos) << bad_out.stderr_text;
  fs::remove_all(in / "right");
  EXPECT_EQ(RunTool("stereo-batch", {in.string(), "-o", out}, tmp.path()).exit_code, 3);
}

TEST(StereoBatch, LeftReferenceAndSubsamplingRun) {
  ScopedTempDir tmp;
  const fs::path out = tmp.path() / "out";
  const auto run = RunTool("stereo-batch", {TestDataPath("stereo_pairs").string(), "-o", out.string(), "-q",
                                            "--reference", "left", "--step", "5x4", "--rows", "130:233",
                                            "--disparity", "20:90"}, tmp.path());
  ASSERT_EQ(run.exit_code, 0) << run.stderr_text;
  const cv::Mat d = io::ReadPfm(out / "disparity" / "frame0000.pfm");
  EXPECT_EQ(io::ReadJson(out / "summary.json")["options"]["step_px"], nlohmann::json({5, 4}));
  const nlohmann::json grid = io::ReadJson(out / "disparity" / "frame0000.json")["disparity"]["grid"];
  ASSERT_EQ(grid["step_px"], nlohmann::json({5, 4}));
  const int ox = grid["origin_px"][0], oy = grid["origin_px"][1];
  const bool full = d.cols == 640 && d.rows == 480;  // else the grid's samples, row by row
  // The truth is on the right image's grid (x_left = x_right + d): a left pixel x with
  // disparity d sees the right pixel x - d, whose true disparity is d.
  const cv::Mat truth_png = cv::imread(
      (TestDataPath("stereo_pairs") / "truth" / "disparity" / "frame0000.png").string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(truth_png.type(), CV_16UC1);
  long estimates = 0, within_1px = 0, off_band_or_grid = 0;
  for (int r = 0; r < d.rows; ++r) {
    for (int c = 0; c < d.cols; ++c) {
      const float e = d.at<float>(r, c);
      if (!std::isfinite(e)) continue;
      const int y = full ? r : oy + 4 * r, x = full ? c : ox + 5 * c;
      // Only rows 130..233 on the 4-row grid and columns on the 5-column grid hold disparities.
      if (y < 130 || y > 233 || (y - oy) % 4 != 0 || (x - ox) % 5 != 0) ++off_band_or_grid;
      ++estimates;
      const int xr = static_cast<int>(std::lround(x - e));
      if (xr < 0 || xr >= truth_png.cols) continue;
      const double t = truth_png.at<std::uint16_t>(y, xr) / 256.0;  // KITTI's 16-bit scale
      within_1px += t > 0 && std::abs(e - t) <= 1.0;
    }
  }
  EXPECT_EQ(off_band_or_grid, 0);
  // 104 rows / 4 x 640 columns / 5 = 3328 grid points in the band; most have an estimate.
  EXPECT_GT(estimates, 3328 / 2);
  EXPECT_GT(within_1px, 0.9 * estimates) << within_1px << " of " << estimates;
}

}  // namespace
}  // namespace lunarnav
