#include "sim/layered_scene.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include <tbb/parallel_for.h>

#include "util/check.h"

namespace lunarnav::sim {
namespace {

// A well-mixed 32-bit hash of a lattice point (lowbias32 by Chris Wellons).
std::uint32_t Hash(std::int64_t ix, std::int64_t iy, std::uint32_t seed) {
  std::uint32_t h = seed * 0x9E3779B9u ^ static_cast<std::uint32_t>(ix) * 0x85EBCA6Bu ^
                    static_cast<std::uint32_t>(iy) * 0xC2B2AE35u;
  h ^= h >> 16;
  h *= 0x7FEB352Du;
  h ^= h >> 15;
  h *= 0x846CA68Bu;
  h ^= h >> 16;
  return h;
}

double LatticeValue(std::int64_t ix, std::int64_t iy, std::uint32_t seed) {
  return Hash(ix, iy, seed) * (1.0 / 4294967296.0) * 2.0 - 1.0;  // [-1, 1)
}

// Value noise with quintic interpolation (C2-smooth), amplitude in [-1, 1].
double ValueNoise(double x, double y, std::uint32_t seed) {
  const double fx = std::floor(x), fy = std::floor(y);
  const auto ix = static_cast<std::int64_t>(fx), iy = static_cast<std::int64_t>(fy);
  const double tx = x - fx, ty = y - fy;
  const double sx = tx * tx * tx * (tx * (tx * 6 - 15) + 10);
  const double sy = ty * ty * ty * (ty * (ty * 6 - 15) + 10);
  const double v00 = LatticeValue(ix, iy, seed), v10 = LatticeValue(ix + 1, iy, seed);
  const double v01 = LatticeValue(ix, iy + 1, seed), v11 = LatticeValue(ix + 1, iy + 1, seed);
  const double top = v00 + sx * (v10 - v00);
  const double bottom = v01 + sx * (v11 - v01);
  return top + sy * (bottom - top);
}

double LayerDisparity(const PlaneLayer& layer, double x_r, double y) {
  return layer.d0_px + layer.slope_x * x_r + layer.slope_y * y;
}

bool InSupport(const PlaneLayer& layer, double x_r, double y) {
  const cv::Rect2d& r = layer.support_right;
  if (r.width <= 0 || r.height <= 0) return true;
  return x_r >= r.x && x_r < r.x + r.width && y >= r.y && y < r.y + r.height;
}

// The layer seen at a point of one view: the largest disparity among the layers covering it.
// For the left view the layer's right-image abscissa solves x_l = x_r + d(x_r, y).
int VisibleLayer(const std::vector<PlaneLayer>& layers, double x, double y, bool left_view,
                 double* x_r_out, double* d_out) {
  int best = -1;
  double best_d = -std::numeric_limits<double>::infinity();
  for (int k = 0; k < static_cast<int>(layers.size()); ++k) {
    const PlaneLayer& layer = layers[k];
    const double x_r = left_view ? (x - layer.d0_px - layer.slope_y * y) / (1.0 + layer.slope_x) : x;
    if (!InSupport(layer, x_r, y)) continue;
    const double d = LayerDisparity(layer, x_r, y);
    if (d > best_d) {
      best_d = d;
      best = k;
      *x_r_out = x_r;
    }
  }
  *d_out = best_d;
  return best;
}

cv::Mat RenderView(const LayeredSceneOptions& o, bool left_view, cv::Mat* truth) {
  cv::Mat image(o.height, o.width, CV_64FC1);
  truth->create(o.height, o.width, CV_32FC1);
  const int s = o.samples_per_axis;
  tbb::parallel_for(0, o.height, [&](int y) {
    auto* out = image.ptr<double>(y);
    auto* gt = truth->ptr<float>(y);
    for (int x = 0; x < o.width; ++x) {
      double x_r = 0, d = 0;
      const int centre = VisibleLayer(o.layers, x, y, left_view, &x_r, &d);
      gt[x] = centre >= 0 ? static_cast<float>(d) : std::numeric_limits<float>::quiet_NaN();
      double acc = 0;
      for (int sy = 0; sy < s; ++sy) {
        for (int sx = 0; sx < s; ++sx) {
          const double px = x + (sx + 0.5) / s - 0.5, py = y + (sy + 0.5) / s - 0.5;
          const int k = VisibleLayer(o.layers, px, py, left_view, &x_r, &d);
          acc += k >= 0 ? LayerTexture(o.layers[k], x_r, py) : 0.0;
        }
      }
      out[x] = acc / (s * s);
    }
  });
  return image;
}

cv::Mat Quantize(const cv::Mat& image, double gain, double offset, double noise_sigma,
                 std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, noise_sigma > 0 ? noise_sigma : 1.0);
  cv::Mat out(image.size(), CV_8UC1);
  for (int y = 0; y < image.rows; ++y) {
    for (int x = 0; x < image.cols; ++x) {
      double v = gain * image.at<double>(y, x) + offset;
      if (noise_sigma > 0) v += noise(rng);
      out.at<std::uint8_t>(y, x) = static_cast<std::uint8_t>(std::clamp(std::lround(v), 0L, 255L));
    }
  }
  return out;
}

}  // namespace

void LayeredSceneOptions::Validate() const {
  LN_CHECK_ARG(width > 0 && height > 0) << "scene size must be positive";
  LN_CHECK_ARG(samples_per_axis >= 1 && samples_per_axis <= 16) << "samples per axis must be 1..16";
  LN_CHECK_ARG(noise_sigma >= 0) << "noise sigma must be >= 0";
  for (const PlaneLayer& layer : layers) {
    LN_CHECK_ARG(layer.slope_x > -0.9) << "a layer's slope_x must be > -0.9 (it would fold)";
    LN_CHECK_ARG(layer.texture_scale_px > 0) << "texture scale must be positive";
  }
}

double LayerTexture(const PlaneLayer& layer, double x, double y) {
  switch (layer.texture) {
    case TextureKind::kFlat:
      return layer.mean;
    case TextureKind::kStripes:
      return layer.mean + layer.contrast * std::sin(2.0 * M_PI * x / layer.texture_scale_px);
    case TextureKind::kValueNoise: {
      const double s = layer.texture_scale_px;
      const double n = 0.65 * ValueNoise(x / s, y / s, layer.seed) +
                       0.35 * ValueNoise(x / (4 * s), y / (4 * s), layer.seed + 101);
      return layer.mean + layer.contrast * n;
    }
  }
  return layer.mean;
}

RenderedPair RenderLayeredPair(const LayeredSceneOptions& options) {
  options.Validate();
  RenderedPair pair;
  const cv::Mat right = RenderView(options, false, &pair.disparity_right_px);
  const cv::Mat left = RenderView(options, true, &pair.disparity_left_px);
  pair.right = Quantize(right, 1.0, 0.0, options.noise_sigma, options.noise_seed);
  pair.left = Quantize(left, options.left_gain, options.left_offset, options.noise_sigma,
                       options.noise_seed + 1);
  return pair;
}

}  // namespace lunarnav::sim
