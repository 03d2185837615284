#include "telemetry/lowpass.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Dense>

#include "util/check.h"

namespace lunarnav::telemetry {
namespace {

using Complex = std::complex<double>;

// Butterworth prototype poles for 1 rad/s: exp(j pi (2k + n + 1) / (2n)), k = 0..n-1.
std::vector<Complex> ButterworthPoles(int n) {
  std::vector<Complex> poles;
  for (int k = 0; k < n; ++k) {
    poles.push_back(std::polar(1.0, M_PI * (2.0 * k + n + 1) / (2.0 * n)));
  }
  return poles;
}

// Coefficients a_0..a_n of the reverse Bessel polynomial,
// a_k = (2n - k)! / (2^(n-k) k! (n-k)!), whose roots are the poles of the Bessel filter with
// unit group delay at DC.
std::vector<double> ReverseBesselCoefficients(int n) {
  std::vector<double> a(n + 1);
  for (int k = 0; k <= n; ++k) {
    double value = 1.0;
    for (int i = n - k + 1; i <= 2 * n - k; ++i) value *= i;  // (2n-k)! / (n-k)!
    for (int i = 2; i <= k; ++i) value /= i;                   // / k!
    a[k] = value / std::ldexp(1.0, n - k);                     // / 2^(n-k)
  }
  return a;
}

// Roots of sum a_k s^k, as eigenvalues of the companion matrix.
std::vector<Complex> PolynomialRoots(const std::vector<double>& a) {
  const int n = static_cast<int>(a.size()) - 1;
  Eigen::MatrixXd companion = Eigen::MatrixXd::Zero(n, n);
  for (int i = 0; i < n; ++i) companion(0, i) = -a[n - 1 - i] / a[n];
  for (int i = 1; i < n; ++i) companion(i, i - 1) = 1.0;
  Eigen::EigenSolver<Eigen::MatrixXd> solver(companion, false);
  std::vector<Complex> roots;
  for (int i = 0; i < n; ++i) roots.push_back(solver.eigenvalues()[i]);
  return roots;
}

// |H(j w)| of the all-pole analog prototype with unit DC gain.
double AnalogMagnitude(const std::vector<Complex>& poles, double w) {
  Complex h = 1.0;
  for (const Complex& p : poles) h *= -p / (Complex(0, w) - p);
  return std::abs(h);
}

// The frequency where the all-pole prototype is 3 dB down (bisection; |H| falls monotonically).
double MinusThreeDbFrequency(const std::vector<Complex>& poles) {
  double lo = 1e-6, hi = 100.0;
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    (AnalogMagnitude(poles, mid) > 1.0 / std::sqrt(2.0) ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

std::vector<Complex> BesselPoles(int n) {
  std::vector<Complex> poles = PolynomialRoots(ReverseBesselCoefficients(n));
  const double w3 = MinusThreeDbFrequency(poles);
  for (Complex& p : poles) p /= w3;
  return poles;
}

// Group delay at DC, in samples, of sum p_k z^-k: sum k p_k / sum p_k.
double DcDelay(double p0, double p1, double p2) { return (p1 + 2.0 * p2) / (p0 + p1 + p2); }

}  // namespace

std::string ToString(LowPassType type) {
  return type == LowPassType::kButterworth ? "butterworth" : "bessel";
}

LowPassType LowPassTypeFromString(const std::string& name) {
  if (name == "butterworth") return LowPassType::kButterworth;
  if (name == "bessel") return LowPassType::kBessel;
  throw std::invalid_argument("filter: expected 'butterworth' or 'bessel', got '" + name + "'");
}

double BesselDelayNormalizedCutoff(int order) {
  LN_CHECK_ARG(order >= 1 && order <= 8) << "Bessel order must be in 1..8";
  return MinusThreeDbFrequency(PolynomialRoots(ReverseBesselCoefficients(order)));
}

LowPassDesign DesignLowPass(LowPassType type, int order, double cutoff_hz, double sample_rate_hz) {
  const int max_order = type == LowPassType::kButterworth ? 10 : 8;
  LN_CHECK_ARG(order >= 1 && order <= max_order)
      << "filter order: must be in 1.." << max_order << " for " << ToString(type) << ", got " << order;
  LN_CHECK_ARG(std::isfinite(sample_rate_hz) && sample_rate_hz > 0)
      << "sample rate: must be > 0 Hz, got " << sample_rate_hz;
  LN_CHECK_ARG(std::isfinite(cutoff_hz) && cutoff_hz > 0 && cutoff_hz < 0.5 * sample_rate_hz)
      << "cut-off: must be in (0, " << 0.5 * sample_rate_hz << ") Hz (half the sample rate), got "
      << cutoff_hz;
  LowPassDesign design;
  design.type = type;
  design.order = order;
  design.cutoff_hz = cutoff_hz;
  design.sample_rate_hz = sample_rate_hz;

  const double fs2 = 2.0 * sample_rate_hz;
  const double warped = fs2 * std::tan(M_PI * cutoff_hz / sample_rate_hz);  // rad/s
  std::vector<Complex> poles = type == LowPassType::kButterworth ? ButterworthPoles(order) : BesselPoles(order);
  // Keep one pole of each conjugate pair (imag > 0) and the real poles.
  std::vector<Complex> pairs, reals;
  for (const Complex& p : poles) {
    if (std::abs(p.imag()) < 1e-9) {
      reals.push_back({p.real(), 0.0});
    } else if (p.imag() > 0) {
      pairs.push_back(p);
    }
  }
  LN_CHECK(2 * pairs.size() + reals.size() == static_cast<std::size_t>(order));
  auto to_z = [&](Complex s) { return (fs2 + s) / (fs2 - s); };
  for (const Complex& p : pairs) {
    const Complex z = to_z(p * warped);
    Biquad q;
    q.a1 = -2.0 * z.real();
    q.a2 = std::norm(z);
    const double gain = (1.0 + q.a1 + q.a2) / 4.0;  // unit DC gain with zeros at z = -1 (double)
    q.b0 = gain;
    q.b1 = 2.0 * gain;
    q.b2 = gain;
    design.sections.push_back(q);
  }
  for (const Complex& p : reals) {
    const double z = to_z(p * warped).real();
    Biquad q;
    q.a1 = -z;
    const double gain = (1.0 + q.a1) / 2.0;  // zero at z = -1
    q.b0 = gain;
    q.b1 = gain;
    design.sections.push_back(q);
  }
  for (const Biquad& q : design.sections) {
    design.delay_samples += DcDelay(q.b0, q.b1, q.b2) - DcDelay(1.0, q.a1, q.a2);
  }
  return design;
}

std::complex<double> FrequencyResponse(const LowPassDesign& design, double frequency_hz) {
  const Complex z1 = std::polar(1.0, -2.0 * M_PI * frequency_hz / design.sample_rate_hz);  // z^-1
  Complex h = 1.0;
  for (const Biquad& q : design.sections) {
    h *= (q.b0 + q.b1 * z1 + q.b2 * z1 * z1) / (1.0 + q.a1 * z1 + q.a2 * z1 * z1);
  }
  return h;
}

nlohmann::json LowPassDesign::ToJson() const {
  nlohmann::json sos = nlohmann::json::array();
  for (const Biquad& q : sections) sos.push_back({q.b0, q.b1, q.b2, 1.0, q.a1, q.a2});
  return {{"type", ToString(type)},
          {"order", order},
          {"cutoff_hz", cutoff_hz},
          {"sample_rate_hz", sample_rate_hz},
          {"delay_samples", delay_samples},
          {"method", "analog prototype, bilinear transform with pre-warping"},
          {"sos", sos}};
}

void FilterCausalInPlace(const LowPassDesign& design, double* x, std::size_t n) {
  if (n == 0) return;
  const double level = x[0];  // the steady-state input (and output: unit DC gain) of each stage
  for (const Biquad& q : design.sections) {
    // Transposed direct form II, state at the steady state of a constant input `level`.
    double s1 = level * (q.b1 + q.b2 - q.a1 - q.a2);
    double s2 = level * (q.b2 - q.a2);
    for (std::size_t k = 0; k < n; ++k) {
      const double in = x[k];
      const double out = q.b0 * in + s1;
      s1 = q.b1 * in - q.a1 * out + s2;
      s2 = q.b2 * in - q.a2 * out;
      x[k] = out;
    }
  }
}

CausalLowPass::CausalLowPass(const LowPassDesign& design, double first) {
  LN_CHECK(design.sections.size() <= static_cast<std::size_t>(kMaxSections));
  for (const Biquad& q : design.sections) {
    // At the steady state of a constant input `first` (unit DC gain: every stage outputs it).
    sections_[static_cast<std::size_t>(count_)] = q;
    state_[static_cast<std::size_t>(count_)] = {first * (q.b1 + q.b2 - q.a1 - q.a2), first * (q.b2 - q.a2)};
    ++count_;
  }
}

std::vector<double> FilterCausal(const LowPassDesign& design, const std::vector<double>& x) {
  std::vector<double> y = x;
  FilterCausalInPlace(design, y.data(), y.size());
  return y;
}

std::vector<double> FilterZeroPhase(const LowPassDesign& design, const std::vector<double>& x) {
  const int n = static_cast<int>(x.size());
  LN_CHECK_ARG(n >= 2) << "zero-phase filtering needs at least 2 samples";
  // Odd reflection about each end, as long as the filter's memory (as scipy's filtfilt).
  const int pad = std::min(n - 1, 3 * (2 * static_cast<int>(design.sections.size()) + 1));
  std::vector<double> ext;
  ext.reserve(n + 2 * pad);
  for (int i = pad; i >= 1; --i) ext.push_back(2.0 * x.front() - x[i]);
  ext.insert(ext.end(), x.begin(), x.end());
  for (int i = 1; i <= pad; ++i) ext.push_back(2.0 * x.back() - x[n - 1 - i]);
  std::vector<double> forward = FilterCausal(design, ext);
  std::reverse(forward.begin(), forward.end());
  std::vector<double> backward = FilterCausal(design, forward);
  std::reverse(backward.begin(), backward.end());
  return std::vector<double>(backward.begin() + pad, backward.begin() + pad + n);
}

}  // namespace lunarnav::telemetry
