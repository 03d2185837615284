#include "stereo/vertical_alignment.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Dense>
#include <opencv2/imgproc.hpp>

#include "util/check.h"
#include "util/errors.h"

namespace lunarnav::stereo {

namespace {

// The surface's terms at scaled position (u, v).
std::array<double, kVerticalTerms> Terms(double u, double v) {
  return {1.0, u, v, u * u, u * v, v * v, u * u * u, u * u * v, u * v * v, v * v * v};
}

double ScaledColumn(double x_px, int width_px) { return (x_px - 0.5 * (width_px - 1)) / (0.5 * width_px); }
double ScaledRow(double y_px, int height_px) { return (y_px - 0.5 * (height_px - 1)) / (0.5 * height_px); }

double Median(std::vector<double> v) {
  if (v.empty()) return 0;
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

}  // namespace

double VerticalMisalignment::OffsetPx(double x_px, double y_px) const {
  const double u = std::clamp(ScaledColumn(x_px, width_px), u_min, u_max);
  const double v = std::clamp(ScaledRow(y_px, height_px), v_min, v_max);
  const std::array<double, kVerticalTerms> t = Terms(u, v);
  double s = 0;
  for (std::size_t k = 0; k < t.size(); ++k) s += coefficients[k] * t[k];
  return s;
}

double VerticalMisalignment::MaxAbsOffsetPx() const {
  double m = 0;
  constexpr int kSteps = 32;
  for (int i = 0; i <= kSteps; ++i) {
    for (int j = 0; j <= kSteps; ++j) {
      m = std::max(m, std::abs(OffsetPx((width_px - 1) * i / double(kSteps), (height_px - 1) * j / double(kSteps))));
    }
  }
  return m;
}

VerticalMisalignment VerticalMisalignment::Plus(const VerticalMisalignment& residual) const {
  LN_CHECK(residual.width_px == width_px && residual.height_px == height_px) << "surfaces of different images";
  VerticalMisalignment sum = *this;
  for (std::size_t k = 0; k < coefficients.size(); ++k) sum.coefficients[k] += residual.coefficients[k];
  sum.u_min = std::min(u_min, residual.u_min);
  sum.u_max = std::max(u_max, residual.u_max);
  sum.v_min = std::min(v_min, residual.v_min);
  sum.v_max = std::max(v_max, residual.v_max);
  return sum;
}

nlohmann::json VerticalMisalignment::ToJson() const {
  return {{"model", "offset = c0 + c1 u + c2 v + c3 u^2 + c4 u v + c5 v^2 + c6 u^3 + c7 u^2 v + c8 u v^2 + c9 v^3 "
                    "(px, the other image's row minus the reference's); u = (x - (width - 1) / 2) / (width / 2), v likewise with y and height, each "
                    "clamped to its span"},
          {"coefficients_px", coefficients},
          {"span_u", {u_min, u_max}},
          {"span_v", {v_min, v_max}},
          {"size_px", {width_px, height_px}}};
}

VerticalMisalignment VerticalMisalignment::FromJson(const nlohmann::json& j, const std::string& source) {
  auto number = [&](const nlohmann::json& v, const char* what) {
    LN_CHECK_INPUT(v.is_number() && std::isfinite(v.get<double>())) << source << ": " << what << ": not a finite number";
    return v.get<double>();
  };
  LN_CHECK_INPUT(j.is_object()) << source << ": the misalignment is not an object";
  VerticalMisalignment m;
  const nlohmann::json& c = j.contains("coefficients_px") ? j["coefficients_px"] : nlohmann::json();
  LN_CHECK_INPUT(c.is_array() && c.size() == static_cast<std::size_t>(kVerticalTerms))
      << source << ": coefficients_px: " << kVerticalTerms << " numbers expected";
  for (int k = 0; k < kVerticalTerms; ++k) {
    m.coefficients[k] = number(c[k], "coefficients_px");
    LN_CHECK_INPUT(std::abs(m.coefficients[k]) <= 50) << source << ": coefficients_px: " << m.coefficients[k]
                                                       << " px is no residual misalignment";
  }
  for (const char* key : {"span_u", "span_v", "size_px"}) {
    LN_CHECK_INPUT(j.contains(key) && j[key].is_array() && j[key].size() == 2) << source << ": " << key << ": two numbers expected";
  }
  m.u_min = number(j["span_u"][0], "span_u");
  m.u_max = number(j["span_u"][1], "span_u");
  m.v_min = number(j["span_v"][0], "span_v");
  m.v_max = number(j["span_v"][1], "span_v");
  LN_CHECK_INPUT(-1 <= m.u_min && m.u_min <= m.u_max && m.u_max <= 1 && -1 <= m.v_min && m.v_min <= m.v_max &&
                 m.v_max <= 1)
      << source << ": span_u and span_v: MIN <= MAX within [-1, 1] expected";
  const double w = number(j["size_px"][0], "size_px"), h = number(j["size_px"][1], "size_px");
  LN_CHECK_INPUT(w >= 1 && h >= 1 && w <= 65536 && h <= 65536 && w == std::floor(w) && h == std::floor(h))
      << source << ": size_px: two whole numbers of pixels expected";
  m.width_px = static_cast<int>(w);
  m.height_px = static_cast<int>(h);
  return m;
}

std::vector<VerticalSample> MeasureVerticalOffsets(const cv::Mat& left, const cv::Mat& right, int bits,
                                                   const cv::Mat& disparity, int step_x_px, int step_y_px,
                                                   calib::ReferenceImage reference,
                                                   const VerticalMeasureOptions& options) {
  LN_CHECK_ARG(options.stride_px >= 1 && options.window_px >= 3 && options.window_px % 2 == 1 &&
               options.iterations >= 1)
      << "vertical alignment: stride >= 1, an odd window >= 3 and at least one iteration";
  LN_CHECK(left.size() == right.size() && disparity.size() == left.size() && disparity.type() == CV_32FC1 &&
           step_x_px >= 1 && step_y_px >= 1)
      << "a pair and its disparity map";
  const bool right_reference = reference == calib::ReferenceImage::kRight;
  const double to_8bit = left.depth() == CV_8U ? 1.0 : 255.0 / (std::ldexp(1.0, std::clamp(bits, 1, 16)) - 1.0);
  cv::Mat ref, other, ref_gx, ref_gy, other_gx, other_gy;
  (right_reference ? right : left).convertTo(ref, CV_32F, to_8bit);
  (right_reference ? left : right).convertTo(other, CV_32F, to_8bit);
  // Central differences (half the [-1 0 1] kernel): grey levels per pixel.
  cv::Sobel(ref, ref_gx, CV_32F, 1, 0, 1, 0.5);
  cv::Sobel(ref, ref_gy, CV_32F, 0, 1, 1, 0.5);
  cv::Sobel(other, other_gx, CV_32F, 1, 0, 1, 0.5);
  cv::Sobel(other, other_gy, CV_32F, 0, 1, 1, 0.5);
  const int h = options.window_px / 2, w = left.cols, rows = left.rows;
  const int margin = h + static_cast<int>(std::ceil(std::max(options.max_offset_px, options.max_shift_px))) + 2;
  const float sign = right_reference ? 1.0f : -1.0f;  // the other image's column: x + sign * d
  // The disparity at image pixel (x, y): the nearest point of the map's grid (origin (0, 0), the
  // steps given; the map has the image's size, NaN between the grid's points).
  const int last_x = (disparity.cols - 1) / step_x_px * step_x_px;
  const int last_y = (disparity.rows - 1) / step_y_px * step_y_px;
  auto disparity_at = [&](int x, int y) {
    const int gx = std::min((x + step_x_px / 2) / step_x_px * step_x_px, last_x);
    const int gy = std::min((y + step_y_px / 2) / step_y_px * step_y_px, last_y);
    return disparity.at<float>(gy, gx);
  };
  auto bilinear = [&](const cv::Mat& m, float x, float y) {
    const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
    const float ax = x - x0, ay = y - y0;
    const float* r0 = m.ptr<float>(y0);
    const float* r1 = m.ptr<float>(y0 + 1);
    return (1 - ay) * ((1 - ax) * r0[x0] + ax * r0[x0 + 1]) + ay * ((1 - ax) * r1[x0] + ax * r1[x0 + 1]);
  };
  const int n_window = options.window_px * options.window_px;
  std::vector<float> xs(n_window), ys(n_window), values(n_window);
  std::vector<VerticalSample> samples;
  for (int y = margin; y < rows - margin; y += options.stride_px) {
    for (int x = margin; x < w - margin; x += options.stride_px) {
      const float d = disparity_at(x, y);
      if (!std::isfinite(d)) continue;
      // The window's pixels with a match, each carried to the other image by its own disparity
      // (a slanted surface's columns shift by different amounts from row to row), and the
      // reference's texture there: it must fix a position in both directions.
      int n = 0;
      double sxx = 0, sxy = 0, syy = 0, mean_ref = 0;
      for (int j = -h; j <= h; ++j) {
        for (int i = -h; i <= h; ++i) {
          const float dij = disparity_at(x + i, y + j);
          if (!std::isfinite(dij)) continue;
          const float xo = static_cast<float>(x + i) + sign * dij;
          if (xo < options.max_shift_px + 1 || xo >= w - 2 - options.max_shift_px) continue;
          const float gx = ref_gx.at<float>(y + j, x + i), gy = ref_gy.at<float>(y + j, x + i);
          sxx += gx * gx;
          sxy += gx * gy;
          syy += gy * gy;
          xs[n] = xo;
          ys[n] = static_cast<float>(y + j);
          values[n] = ref.at<float>(y + j, x + i);
          mean_ref += values[n];
          ++n;
        }
      }
      if (n < n_window * 3 / 4) continue;
      sxx /= n;
      sxy /= n;
      syy /= n;
      const double min_eigenvalue = 0.5 * (sxx + syy) - std::sqrt(0.25 * (sxx - syy) * (sxx - syy) + sxy * sxy);
      if (min_eigenvalue < options.min_texture) continue;
      mean_ref /= n;
      // Gauss-Newton on a shift of the other image's window, each pixel at its match's column:
      // down by the row offset, and along the rows by a common correction of the matches (where
      // the rows are off, the matcher's columns lean towards the offset on oblique texture; a
      // fixed column would take part of the offset for it). Means taken out: the gains differ.
      double offset = 0, shift = 0;
      bool converged = false;
      for (int iteration = 0; iteration < options.iterations; ++iteration) {
        const float dx = static_cast<float>(shift), dy = static_cast<float>(offset);
        double mean_other = 0;
        for (int k = 0; k < n; ++k) mean_other += bilinear(other, xs[k] + dx, ys[k] + dy);
        mean_other /= n;
        double axx = 0, axy = 0, ayy = 0, bx = 0, by = 0;
        for (int k = 0; k < n; ++k) {
          const float xo = xs[k] + dx, yo = ys[k] + dy;
          const double r = (bilinear(other, xo, yo) - mean_other) - (values[k] - mean_ref);
          const double gx = bilinear(other_gx, xo, yo), gy = bilinear(other_gy, xo, yo);
          axx += gx * gx;
          axy += gx * gy;
          ayy += gy * gy;
          bx += gx * r;
          by += gy * r;
        }
        const double det = axx * ayy - axy * axy;
        if (!(det > 0)) break;
        const double step_x = -(ayy * bx - axy * by) / det, step_y = -(axx * by - axy * bx) / det;
        shift += std::clamp(step_x, -0.5, 0.5);
        offset += std::clamp(step_y, -0.5, 0.5);
        if (std::abs(offset) > options.max_offset_px || std::abs(shift) > options.max_shift_px) break;
        if (std::abs(step_x) < 0.005 && std::abs(step_y) < 0.005) {
          converged = true;
          break;
        }
      }
      if (!converged) continue;
      samples.push_back({static_cast<float>(x + 0.5 * (sign * d + shift)), static_cast<float>(y + 0.5 * offset),
                         static_cast<float>(offset)});
    }
  }
  return samples;
}

std::optional<VerticalMisalignment> FitVerticalMisalignment(const std::vector<VerticalSample>& samples, cv::Size size,
                                                            VerticalFitReport* report) {
  VerticalFitReport r;
  r.samples = static_cast<int>(samples.size());
  if (report != nullptr) *report = r;
  if (r.samples < kMinVerticalSamples) return std::nullopt;
  const int n = r.samples;
  Eigen::MatrixXd a(n, kVerticalTerms);
  Eigen::VectorXd b(n);
  std::vector<double> abs_offsets(n);
  for (int i = 0; i < n; ++i) {
    const std::array<double, kVerticalTerms> t =
        Terms(ScaledColumn(samples[i].x_px, size.width), ScaledRow(samples[i].y_px, size.height));
    for (int k = 0; k < kVerticalTerms; ++k) a(i, k) = t[k];
    b(i) = samples[i].offset_px;
    abs_offsets[i] = std::abs(b(i));
  }
  r.median_abs_offset_px = Median(abs_offsets);
  // Iteratively trimmed least squares: samples more than 3 robust deviations off the surface
  // (a tracker caught by a depth edge, a repeated texture) leave the fit. A light ridge on the
  // curved terms keeps a fit over a narrow band of rows well posed.
  std::vector<char> keep(n, 1);
  Eigen::VectorXd c = Eigen::VectorXd::Zero(kVerticalTerms);
  double sigma = 0;
  for (int iteration = 0; iteration < 6; ++iteration) {
    Eigen::MatrixXd normal = Eigen::MatrixXd::Zero(kVerticalTerms, kVerticalTerms);
    Eigen::VectorXd rhs = Eigen::VectorXd::Zero(kVerticalTerms);
    int kept = 0;
    for (int i = 0; i < n; ++i) {
      if (!keep[i]) continue;
      normal.noalias() += a.row(i).transpose() * a.row(i);
      rhs.noalias() += a.row(i).transpose() * b(i);
      ++kept;
    }
    if (kept < kMinVerticalSamples) return std::nullopt;
    for (int k = 1; k < kVerticalTerms; ++k) normal(k, k) += 1e-3 * kept;
    c = normal.ldlt().solve(rhs);
    std::vector<double> residuals;
    residuals.reserve(kept);
    for (int i = 0; i < n; ++i) {
      if (keep[i]) residuals.push_back(std::abs(b(i) - a.row(i).dot(c)));
    }
    sigma = std::max(1.4826 * Median(residuals), 0.02);
    bool changed = false;
    for (int i = 0; i < n; ++i) {
      const char k = std::abs(b(i) - a.row(i).dot(c)) <= 3 * sigma ? 1 : 0;
      changed |= k != keep[i];
      keep[i] = k;
    }
    if (!changed) break;
  }
  VerticalMisalignment m;
  m.width_px = size.width;
  m.height_px = size.height;
  for (int k = 0; k < kVerticalTerms; ++k) m.coefficients[k] = c(k);
  m.u_min = m.v_min = 1;
  m.u_max = m.v_max = -1;
  for (int i = 0; i < n; ++i) {
    if (!keep[i]) continue;
    ++r.samples_kept;
    m.u_min = std::min(m.u_min, a(i, 1));
    m.u_max = std::max(m.u_max, a(i, 1));
    m.v_min = std::min(m.v_min, a(i, 2));
    m.v_max = std::max(m.v_max, a(i, 2));
  }
  r.residual_px = sigma;
  std::vector<double> surface;
  surface.reserve(r.samples_kept);
  for (int i = 0; i < n; ++i) {
    if (keep[i]) surface.push_back(std::abs(a.row(i).dot(c)));
  }
  const auto q = surface.begin() + static_cast<std::ptrdiff_t>(0.95 * (surface.size() - 1));
  std::nth_element(surface.begin(), q, surface.end());
  r.surface_p95_abs_px = *q;
  if (report != nullptr) *report = r;
  return m;
}

VerticalResampler::VerticalResampler(const VerticalMisalignment& misalignment, calib::ReferenceImage reference)
    : reference_(reference) {
  const int w = misalignment.width_px, h = misalignment.height_px;
  LN_CHECK_ARG(w > 0 && h > 0) << "vertical alignment: an empty image";
  cv::Mat xs(h, w, CV_32FC1), ref_y(h, w, CV_32FC1), other_y(h, w, CV_32FC1);
  // The reference pixel (x, y) shows what the reference's row y - offset / 2 held, the other
  // image's (x, y) its row y + offset / 2: a point offset rows apart lands on one row.
  for (int y = 0; y < h; ++y) {
    float* px = xs.ptr<float>(y);
    float* pr = ref_y.ptr<float>(y);
    float* po = other_y.ptr<float>(y);
    for (int x = 0; x < w; ++x) {
      const double half = 0.5 * misalignment.OffsetPx(x, y);
      px[x] = static_cast<float>(x);
      pr[x] = static_cast<float>(y - half);
      po[x] = static_cast<float>(y + half);
    }
  }
  cv::convertMaps(xs, ref_y, reference_map1_, reference_map2_, CV_16SC2);
  cv::convertMaps(xs, other_y, other_map1_, other_map2_, CV_16SC2);
}

void VerticalResampler::Apply(cv::Mat* left, cv::Mat* right) const {
  const bool right_reference = reference_ == calib::ReferenceImage::kRight;
  cv::Mat* ref = right_reference ? right : left;
  cv::Mat* other = right_reference ? left : right;
  LN_CHECK(ref->size() == reference_map1_.size() && other->size() == other_map1_.size())
      << "vertical alignment: images of another size";
  cv::Mat out;
  cv::remap(*ref, out, reference_map1_, reference_map2_, cv::INTER_CUBIC, cv::BORDER_REPLICATE);
  *ref = out;
  cv::Mat out2;
  cv::remap(*other, out2, other_map1_, other_map2_, cv::INTER_CUBIC, cv::BORDER_REPLICATE);
  *other = out2;
}

}  // namespace lunarnav::stereo
