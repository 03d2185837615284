// stereo_realdata_benchmark: stereo-batch's presets side by side with OpenCV's StereoSGBM and
// StereoBM on real pairs with ground truth, in one run: accuracy (KITTI's D1, bad-N, density)
// and time per pair. docs/performance.md and docs/stereo-matcher.md show its table.
//
//   stereo_realdata_benchmark [--stereo-batch PATH] [--threads N] [--repeat R]
//                             [--downscale K[,K...]] [--keep DIR] [--quality-args ARGS] DIR...
//
// Each DIR is a KITTI 2015 layout (image_2/, image_3/, disp_noc_0/ with <stem>.png), a
// Middlebury 2014 pair (im0.png, im1.png, disp0GT.pfm, mask0nocc.png, calib.txt), a
// Middlebury 2005/2006 pair (view1 and view5 .png or .jpg, disp1.png: 8-bit, the full-size
// disparity, 0 = unknown), or a folder of such sets (each subfolder is one). Inputs are read as
// 8-bit grey (Rec. 601 luma).
//
// --downscale scores every Middlebury pair at each listed integer factor (default 1): the
// images are block averages (OpenCV's INTER_AREA); a block's truth is the mean of its pixels'
// truths divided by K when every pixel of the block has a non-occluded truth and they span at
// most K full-size pixels (1 px at the new size), none otherwise (depth edges are not scored
// at a size where a block straddles them). The 2005/2006 sets give no occlusion mask: a pixel
// is occluded when a pixel to its right with a greater disparity lands on or left of its
// match (x - d) in the other view, by more than half a pixel. KITTI sets are scored as given.
// --keep DIR keeps the prepared inputs and every method's disparity map (PFM) in DIR.
// --quality-args ARGS appends ARGS (words for the shell, e.g. "--gradient-weight 0") to the
// quality preset's stereo-batch command: a variant of the default measured in the same table.
//
// stereo-batch runs as a separate process per pair (the whole process is timed: start-up,
// decoding, matching, writing); OpenCV's matchers are timed on the decoded grey images. Times
// are medians over R runs.
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <limits>
#include <map>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "evaluation/disparity_eval.h"
#include "io/image_io.h"
#include "util/check.h"
#include "util/errors.h"

namespace fs = std::filesystem;
using namespace lunarnav;

namespace {

struct Pair {
  std::string stem;
  fs::path left, right, truth, mask;
};

struct Dataset {
  std::string name;
  std::string kind;  // "kitti", "middlebury" (2014 layout) or "middlebury2006"
  std::vector<Pair> pairs;
  int num_disparities = 128;
  double png_truth_scale = 256.0;
};

// The first of DIR/STEM.png and DIR/STEM.jpg that exists, or "".
fs::path FirstImage(const fs::path& dir, const std::string& stem) {
  for (const char* ext : {".png", ".jpg"}) {
    if (fs::is_regular_file(dir / (stem + ext))) return dir / (stem + ext);
  }
  return {};
}

int RoundUp16(int v) { return (v + 15) / 16 * 16; }

std::vector<Dataset> FindDatasets(const fs::path& dir) {
  std::vector<Dataset> sets;
  if (fs::is_directory(dir / "image_2") && fs::is_directory(dir / "image_3") && fs::is_directory(dir / "disp_noc_0")) {
    Dataset d{dir.filename().string(), "kitti", {}, 128, 256.0};
    std::vector<fs::path> files;
    for (const auto& e : fs::directory_iterator(dir / "disp_noc_0")) files.push_back(e.path());
    std::sort(files.begin(), files.end());
    for (const fs::path& t : files) {
      if (t.extension() != ".png") continue;
      const std::string name = t.filename().string();
      d.pairs.push_back({t.stem().string(), dir / "image_2" / name, dir / "image_3" / name, t, {}});
    }
    sets.push_back(d);
    return sets;
  }
  if (fs::is_regular_file(dir / "im0.png") && fs::is_regular_file(dir / "disp0GT.pfm")) {
    Dataset d{dir.filename().string(), "middlebury", {}, 128, 1.0};
    std::ifstream calib(dir / "calib.txt");
    std::string line;
    while (std::getline(calib, line)) {
      if (line.rfind("ndisp=", 0) == 0) d.num_disparities = RoundUp16(std::stoi(line.substr(6)));
    }
    d.pairs.push_back({dir.filename().string(), dir / "im0.png", dir / "im1.png", dir / "disp0GT.pfm",
                       fs::is_regular_file(dir / "mask0nocc.png") ? dir / "mask0nocc.png" : fs::path()});
    sets.push_back(d);
    return sets;
  }
  if (!FirstImage(dir, "view1").empty() && !FirstImage(dir, "view5").empty() &&
      fs::is_regular_file(dir / "disp1.png")) {
    Dataset d{dir.filename().string(), "middlebury2006", {}, 128, 1.0};
    d.pairs.push_back({dir.filename().string(), FirstImage(dir, "view1"), FirstImage(dir, "view5"),
                       dir / "disp1.png", {}});
    sets.push_back(d);
    return sets;
  }
  std::vector<fs::path> subdirs;
  for (const auto& e : fs::directory_iterator(dir)) {
    if (e.is_directory()) subdirs.push_back(e.path());
  }
  std::sort(subdirs.begin(), subdirs.end());
  for (const fs::path& s : subdirs) {
    for (Dataset& d : FindDatasets(s)) sets.push_back(std::move(d));
  }
  return sets;
}

double Median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? NAN : (v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]));
}

double Now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// The truth (CV_32FC1, NaN = none) of a Middlebury 2005/2006 disp1.png: 8-bit, the full-size
// disparity, 0 = unknown.
cv::Mat ReadMiddlebury2006Truth(const fs::path& path) {
  const cv::Mat raw = io::ReadGreyImage(path);
  LN_CHECK_INPUT(raw.type() == CV_8UC1) << path.string() << ": an 8-bit disparity image expected";
  cv::Mat truth;
  raw.convertTo(truth, CV_32F);
  truth.setTo(NAN, raw == 0);
  return truth;
}

// 255 where the left view's truth is known and seen by the right view, 0 elsewhere: scanning
// each row from the right, a pixel is occluded when a pixel right of it lands more than half a
// pixel left of its own match x - d.
cv::Mat NonOccludedMask(const cv::Mat& truth) {
  cv::Mat mask(truth.size(), CV_8UC1, cv::Scalar(0));
  for (int y = 0; y < truth.rows; ++y) {
    const float* t = truth.ptr<float>(y);
    std::uint8_t* m = mask.ptr<std::uint8_t>(y);
    double least_match = std::numeric_limits<double>::infinity();
    for (int x = truth.cols - 1; x >= 0; --x) {
      if (!std::isfinite(t[x])) continue;
      const double match = x - t[x];
      if (match <= least_match + 0.5) m[x] = 255;
      least_match = std::min(least_match, match);
    }
  }
  return mask;
}

// The truth at 1/k size: a k x k block's mean / k where all its pixels are scored and span at
// most k full-size pixels, NaN elsewhere.
cv::Mat DownscaleTruth(const cv::Mat& truth, const cv::Mat& mask, int k) {
  cv::Mat out(truth.rows / k, truth.cols / k, CV_32FC1, cv::Scalar(NAN));
  for (int y = 0; y < out.rows; ++y) {
    for (int x = 0; x < out.cols; ++x) {
      double sum = 0, lo = std::numeric_limits<double>::infinity(), hi = -lo;
      bool all = true;
      for (int v = y * k; v < (y + 1) * k && all; ++v) {
        for (int u = x * k; u < (x + 1) * k; ++u) {
          const float t = truth.at<float>(v, u);
          if (!std::isfinite(t) || (!mask.empty() && mask.at<std::uint8_t>(v, u) != 255)) {
            all = false;
            break;
          }
          sum += t;
          lo = std::min<double>(lo, t);
          hi = std::max<double>(hi, t);
        }
      }
      if (all && hi - lo <= k) out.at<float>(y, x) = static_cast<float>(sum / (k * k) / k);
    }
  }
  return out;
}

// Writes the pair of a Middlebury set at 1/k size in the 2014 layout under `dir` and returns
// the set that reads it (KITTI sets and 2014 sets at k = 1 are returned as given).
Dataset Prepare(const Dataset& d, int k, const fs::path& dir) {
  if (d.kind == "kitti" || (d.kind == "middlebury" && k == 1)) return d;
  Dataset out = d;
  out.kind = "middlebury";
  out.name = k == 1 ? d.name : d.name + " /" + std::to_string(k);
  out.pairs.clear();
  for (const Pair& p : d.pairs) {
    const fs::path to = dir / (p.stem + "_" + std::to_string(k));
    fs::create_directories(to);
    cv::Mat truth, mask;
    if (d.kind == "middlebury2006") {
      truth = ReadMiddlebury2006Truth(p.truth);
      mask = NonOccludedMask(truth);
    } else {
      truth = evaluation::ReadTruthDisparity(p.truth, 1.0);
      if (!p.mask.empty()) mask = io::ReadGreyImage(p.mask);
    }
    for (const auto& [from, name] : {std::pair{p.left, "im0.png"}, std::pair{p.right, "im1.png"}}) {
      cv::Mat image = io::ReadImage(from), small;
      if (k == 1) {
        small = image;
      } else {
        cv::resize(image(cv::Rect(0, 0, image.cols / k * k, image.rows / k * k)), small,
                   cv::Size(image.cols / k, image.rows / k), 0, 0, cv::INTER_AREA);
      }
      io::WriteImageAtomic(to / name, small);
    }
    const cv::Mat small_truth = k == 1 ? truth.clone() : DownscaleTruth(truth, mask, k);
    cv::Mat small_mask = k == 1 && !mask.empty() ? mask : cv::Mat(small_truth == small_truth);  // NaN != NaN
    double max_truth = 0;
    cv::minMaxIdx(small_truth, nullptr, &max_truth, nullptr, nullptr, small_mask);
    cv::Mat pfm_truth = small_truth.clone();
    pfm_truth.setTo(std::numeric_limits<float>::infinity(), small_truth != small_truth);
    io::WriteImageAtomic(to / "disp0GT.pfm", pfm_truth);
    io::WriteImageAtomic(to / "mask0nocc.png", small_mask);
    out.num_disparities = d.kind == "middlebury2006" ? RoundUp16(static_cast<int>(std::ceil(max_truth)) + 2)
                                                     : RoundUp16((d.num_disparities + k - 1) / k);
    out.pairs.push_back({k == 1 ? p.stem : p.stem + "_" + std::to_string(k), to / "im0.png", to / "im1.png",
                         to / "disp0GT.pfm", to / "mask0nocc.png"});
  }
  return out;
}

struct MethodScores {
  evaluation::DisparityScores scores;
  std::vector<double> seconds;  // per pair: the median over the repeats
};

// The mask: Middlebury's 255 = non-occluded (128 occluded, 0 unknown; scored with
// mask_min_value 255); none for KITTI.
cv::Mat ReadMask(const Pair& p) { return p.mask.empty() ? cv::Mat() : io::ReadGreyImage(p.mask); }

void Score(const cv::Mat& estimate, const Pair& p, const Dataset& d, MethodScores* out) {
  evaluation::DisparityEvalOptions options;
  options.bad_thresholds_px = {1.0, 2.0, 3.0};
  options.png_truth_scale = d.png_truth_scale;
  options.mask_min_value = 255;
  const cv::Mat truth = evaluation::ReadTruthDisparity(p.truth, d.png_truth_scale);
  out->scores.Add(evaluation::ScoreDisparity(estimate, truth, ReadMask(p), {}, options));
}

int RunCommand(const std::string& command) {
  const int status = std::system(command.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::string Fixed(double v, int digits) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(digits) << v;
  return s.str();
}

}  // namespace

int Run(int argc, char** argv) {
  std::string stereo_batch = "stereo-batch";
  int threads = 2, repeat = 3;
  std::vector<fs::path> dirs;
  std::vector<int> downscales;
  fs::path keep;
  std::string quality_args;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--stereo-batch" && i + 1 < argc) {
      stereo_batch = argv[++i];
    } else if (a == "--threads" && i + 1 < argc) {
      threads = std::atoi(argv[++i]);
    } else if (a == "--repeat" && i + 1 < argc) {
      repeat = std::max(1, std::atoi(argv[++i]));
    } else if (a == "--downscale" && i + 1 < argc) {
      std::stringstream list(argv[++i]);
      for (std::string k; std::getline(list, k, ',');) {
        const int v = std::atoi(k.c_str());
        if (v < 1 || v > 16) {
          std::cerr << "error: --downscale: " << k << " is not an integer factor in [1, 16]\n";
          return 2;
        }
        downscales.push_back(v);
      }
    } else if (a == "--keep" && i + 1 < argc) {
      keep = argv[++i];
    } else if (a == "--quality-args" && i + 1 < argc) {
      quality_args = argv[++i];
    } else if (a == "-h" || a == "--help") {
      std::cout << "usage: stereo_realdata_benchmark [--stereo-batch PATH] [--threads N] [--repeat R] "
                   "[--downscale K[,K...]] [--keep DIR] [--quality-args ARGS] DIR...\n";
      return 0;
    } else {
      dirs.emplace_back(a);
    }
  }
  if (dirs.empty()) {
    std::cerr << "error: no data directory given (usage: stereo_realdata_benchmark [options] DIR...)\n";
    return 2;
  }
  if (stereo_batch.find('/') == std::string::npos) {
    // Next to this program by default (build/bin).
    const fs::path self = fs::canonical("/proc/self/exe").parent_path() / stereo_batch;
    if (fs::exists(self)) stereo_batch = self.string();
  }
  cv::setNumThreads(threads);
  if (downscales.empty()) downscales = {1};
  const fs::path work =
      keep.empty() ? fs::temp_directory_path() / ("lunarnav_realdata_bench_" + std::to_string(::getpid())) : keep;
  std::vector<Dataset> found;
  for (const fs::path& d : dirs) {
    if (!fs::is_directory(d)) {
      std::cerr << "error: " << d.string() << ": not a directory\n";
      return 3;
    }
    for (Dataset& s : FindDatasets(d)) found.push_back(std::move(s));
  }
  std::vector<Dataset> sets;
  for (const Dataset& d : found) {
    for (const int k : downscales) {
      if (d.kind == "kitti" && k != downscales.front()) continue;
      sets.push_back(Prepare(d, k, work / "prepared"));
    }
  }
  if (sets.empty()) {
    std::cerr << "error: no KITTI or Middlebury data found under the given directories\n";
    return 3;
  }
  std::cout << "| data | method | pairs | density (%) | D1 (%) | D1 or missing (%) | bad-1 (%) | bad-2 (%) | "
               "bias (px) | time per pair (s) | time / SGBM |\n|---|---|---|---|---|---|---|---|---|---|---|\n";
  const std::vector<std::string> methods = {"stereo-batch quality", "stereo-batch paper", "OpenCV StereoSGBM HH 5",
                                            "OpenCV StereoBM 15"};
  for (const Dataset& d : sets) {
    std::map<std::string, MethodScores> results;
    for (std::size_t k = 0; k < d.pairs.size(); ++k) {
      const Pair& p = d.pairs[k];
      std::cerr << "[" << d.name << "] " << p.stem << "\n";
      const cv::Mat left = io::ReadGreyImage(p.left), right = io::ReadGreyImage(p.right);
      cv::Mat left8, right8;
      left.convertTo(left8, CV_8U, left.depth() == CV_8U ? 1.0 : 255.0 / 65535.0);
      right.convertTo(right8, CV_8U, right.depth() == CV_8U ? 1.0 : 255.0 / 65535.0);
      const int nd = d.num_disparities;
      // OpenCV's matchers: the median time of `repeat` runs, and the last map scored.
      auto run_opencv = [&](const cv::Ptr<cv::StereoMatcher>& matcher, const std::string& name) {
        cv::Mat disp;
        std::vector<double> times;
        for (int r = 0; r < repeat; ++r) {
          const double t0 = Now();
          matcher->compute(left8, right8, disp);
          times.push_back(Now() - t0);
        }
        MethodScores& m = results[name];
        m.seconds.push_back(Median(times));
        const cv::Mat estimate = evaluation::DisparityFromOpenCv(disp);
        Score(estimate, p, d, &m);
        if (!keep.empty()) {
          fs::create_directories(work / ("out_" + name));
          io::WriteImageAtomic(work / ("out_" + name) / (p.stem + ".pfm"), estimate);
        }
      };
      // StereoSGBM as the issue measures it; StereoBM with block 15.
      run_opencv(cv::StereoSGBM::create(0, nd, 5, 8 * 25, 32 * 25, 0, 0, 10, 100, 2, cv::StereoSGBM::MODE_HH),
                 "OpenCV StereoSGBM HH 5");
      run_opencv(cv::StereoBM::create(nd, 15), "OpenCV StereoBM 15");
      for (const std::string preset : {"quality", "paper"}) {
        const fs::path in = work / "in" / p.stem, out = work / ("out_" + std::string(preset)) / p.stem;
        fs::create_directories(in / "left");
        fs::create_directories(in / "right");
        const std::string ext = p.left.extension().string();
        fs::remove(in / "left" / ("pair" + ext));
        fs::remove(in / "right" / ("pair" + ext));
        fs::create_symlink(fs::absolute(p.left), in / "left" / ("pair" + ext));
        fs::create_symlink(fs::absolute(p.right), in / "right" / ("pair" + ext));
        std::ostringstream cmd;
        cmd << "'" << stereo_batch << "' '" << in.string() << "' -o '" << out.string() << "' --preset " << preset
            << " --reference left --disparity 0:" << nd - 1 << " -j " << threads << " --quiet";
        if (std::string(preset) == "quality" && !quality_args.empty()) cmd << " " << quality_args;
        std::vector<double> times;
        for (int r = 0; r < repeat; ++r) {
          fs::remove_all(out);
          const double t0 = Now();
          const int code = RunCommand(cmd.str());
          times.push_back(Now() - t0);
          if (code != 0) {
            std::cerr << "error: " << cmd.str() << ": exit " << code << "\n";
            return 1;
          }
        }
        MethodScores& m = results["stereo-batch " + std::string(preset)];
        m.seconds.push_back(Median(times));
        Score(io::ReadPfm(out / "disparity" / "pair.pfm"), p, d, &m);
      }
    }
    const double sgbm_time = Median(results["OpenCV StereoSGBM HH 5"].seconds);
    for (const std::string& name : methods) {
      const MethodScores& m = results[name];
      const evaluation::DisparityScores& s = m.scores;
      const double t = Median(m.seconds);
      std::cout << "| " << d.name << " | " << name << " | " << d.pairs.size() << " | " << Fixed(s.DensityPct(), 1)
                << " | " << Fixed(s.D1Pct(), 2) << " | " << Fixed(s.D1OrMissingPct(), 2) << " | "
                << Fixed(s.BadPct(0), 2) << " | " << Fixed(s.BadPct(1), 2) << " | " << Fixed(s.BiasPx(), 2) << " | "
                << Fixed(t, 3) << " | "
                << Fixed(t / sgbm_time, 2) << " |\n";
    }
  }
  std::cout << "\nDensity and errors over the truth pixels (KITTI: disp_noc_0; Middlebury: mask0nocc = 255). "
               "D1: error > 3 px and > 5 % of the truth. Bias: the median of (estimate - truth) over the estimates "
               "within 3 px of the truth (a systematic offset, the matcher's or the calibration's). Times: median "
               "per pair over "
            << repeat << " runs, " << threads
            << " threads; stereo-batch as a whole process per pair, OpenCV on decoded grey images.\n";
  if (keep.empty()) fs::remove_all(work);
  return 0;
}

int main(int argc, char** argv) {
  try {
    return Run(argc, argv);
  } catch (const InputError& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 3;
  } catch (const std::exception& e) {
    std::cerr << "error: internal: " << e.what() << "\n";
    return 1;
  }
}
