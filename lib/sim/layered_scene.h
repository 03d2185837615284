// Rectified stereo pairs of textured planar layers with exact ground-truth disparity.
//
// A stand-in for a full ray-cast terrain simulator where the matcher only needs surfaces of
// known disparity: each layer is a plane whose disparity, in the right image's pixel grid
// (the paper's convention x_l = x_r + d), is d(x, y) = d0 + slope_x * x + slope_y * y over
// a rectangle of the right image. Its texture is attached to the surface (a function of the
// right-image point it projects to), so both images see the same surface and sub-pixel
// disparity is real. Pixels integrate the scene over S x S samples; nearer layers (larger
// disparity) occlude farther ones in each view.
#pragma once

#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

namespace lunarnav::sim {

/// Texture of a layer.
enum class TextureKind {
  kValueNoise,  ///< Two octaves of smooth random value noise (natural, unambiguous).
  kFlat,        ///< Constant intensity (no texture at all).
  kStripes      ///< Vertical sinusoidal stripes of period `texture_scale_px` (repetitive).
};

/// One planar surface of the scene.
struct PlaneLayer {
  double d0_px = 20.0;       ///< Disparity at right-image pixel (0, 0).
  double slope_x = 0.0;      ///< d(d)/dx, px per px.
  double slope_y = 0.0;      ///< d(d)/dy, px per px.
  /// Extent in right-image coordinates; an empty rectangle means the whole plane.
  cv::Rect2d support_right;
  TextureKind texture = TextureKind::kValueNoise;
  double texture_scale_px = 2.0;  ///< Noise cell size or stripe period, right-image pixels.
  double mean = 128.0;            ///< Mean intensity, 8-bit grey levels.
  double contrast = 60.0;         ///< Peak deviation from the mean, grey levels.
  std::uint32_t seed = 1;         ///< Texture seed.
};

/// Options of the renderer.
struct LayeredSceneOptions {
  int width = 640;
  int height = 480;
  std::vector<PlaneLayer> layers;  ///< Drawn nearest-first by disparity at each point.
  int samples_per_axis = 3;        ///< S: S x S samples per pixel (anti-aliasing).
  double noise_sigma = 0.0;        ///< Gaussian sensor noise, grey levels, added per image.
  double left_gain = 1.0, left_offset = 0.0;  ///< Photometric difference of the left camera.
  std::uint32_t noise_seed = 7;
  void Validate() const;
};

/// A rendered pair and its ground truth.
struct RenderedPair {
  cv::Mat left, right;          ///< CV_8UC1.
  cv::Mat disparity_right_px;   ///< CV_32FC1, in right-image pixels; NaN where no layer.
  cv::Mat disparity_left_px;    ///< CV_32FC1, in left-image pixels (x_r = x_l - d); NaN where no layer.
};

/// Renders the scene (deterministic for given options). Uses all cores.
RenderedPair RenderLayeredPair(const LayeredSceneOptions& options);

/// The texture of a layer at right-image point (x, y), in grey levels (not clamped).
double LayerTexture(const PlaneLayer& layer, double x, double y);

}  // namespace lunarnav::sim
