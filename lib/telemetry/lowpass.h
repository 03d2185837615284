// Low-pass IIR filters for sensor streams: Butterworth and Bessel, designed from their analog
// prototypes by the bilinear transform with pre-warping, run causally (as on the rover) or
// forward-backward (zero phase, for logs processed after the fact).
//
// Krotkov & Hebert sec. 4.1: a spectral analysis of the compass put the noise above 0.25 Hz;
// Butterworth and Bessel low-pass filters suppressed it "but also introduced a 2-3 cycle delay".
#pragma once

#include <array>
#include <complex>
#include <cstddef>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace lunarnav::telemetry {

enum class LowPassType {
  kButterworth,  ///< Maximally flat magnitude.
  kBessel        ///< Maximally flat group delay (little overshoot), normalised here so that
                 ///< its magnitude is -3 dB at the cut-off, like the Butterworth's.
};
std::string ToString(LowPassType type);
LowPassType LowPassTypeFromString(const std::string& name);

/// One second-order section: H(z) = (b0 + b1 z^-1 + b2 z^-2) / (1 + a1 z^-1 + a2 z^-2).
/// A first-order section has b2 = a2 = 0.
struct Biquad {
  double b0 = 1, b1 = 0, b2 = 0, a1 = 0, a2 = 0;
};

/// A designed digital low-pass filter.
struct LowPassDesign {
  LowPassType type = LowPassType::kButterworth;
  int order = 2;
  double cutoff_hz = 0.25;
  double sample_rate_hz = 10;
  std::vector<Biquad> sections;  ///< Cascade; unit gain at DC.
  /// Group delay at DC, in samples: how far the causal output lags a slowly varying input.
  double delay_samples = 0;
  nlohmann::json ToJson() const;
};

/// Designs the filter. Method: the analog prototype's poles for a cut-off of 1 rad/s
/// (Butterworth: on the unit circle; Bessel: roots of the reverse Bessel polynomial, scaled so
/// that |H| = 1/sqrt(2) at 1 rad/s) are scaled to the pre-warped cut-off
/// 2 fs tan(pi fc / fs), mapped by the bilinear transform z = (2 fs + s) / (2 fs - s) (the
/// zeros at infinity go to z = -1), paired into second-order sections, and scaled to unit
/// gain at DC. Pre-warping puts the digital filter's -3 dB point exactly at fc.
/// @param order  1..10 (Butterworth) or 1..8 (Bessel).
/// @param cutoff_hz  in (0, sample_rate_hz / 2).
/// @throws std::invalid_argument for a bad order or cut-off.
LowPassDesign DesignLowPass(LowPassType type, int order, double cutoff_hz, double sample_rate_hz);

/// H(e^{j 2 pi f / fs}) of the design.
std::complex<double> FrequencyResponse(const LowPassDesign& design, double frequency_hz);

/// The -3 dB frequency of the analog Bessel prototype normalised for unit delay at DC
/// (1.3617 for order 2, 2.1139 for order 4; the classic table), in rad/s.
double BesselDelayNormalizedCutoff(int order);

/// Runs the filter forward (causal, as on the vehicle), starting in the steady state of the
/// first sample so that the output does not ramp up from zero.
std::vector<double> FilterCausal(const LowPassDesign& design, const std::vector<double>& x);

/// The same in place: `x` (n samples) is replaced by the filter's output.
void FilterCausalInPlace(const LowPassDesign& design, double* x, std::size_t n);

/// The causal filter sample by sample (the numbers of FilterCausalInPlace), for pipelines that
/// stream a log instead of holding it whole.
class CausalLowPass {
 public:
  /// Starts in the steady state of `first`, the first sample.
  CausalLowPass(const LowPassDesign& design, double first);
  double operator()(double x) {
    for (int i = 0; i < count_; ++i) {  // transposed direct form II
      const Biquad& q = sections_[static_cast<std::size_t>(i)];
      double* s = state_[static_cast<std::size_t>(i)].data();
      const double out = q.b0 * x + s[0];
      s[0] = q.b1 * x - q.a1 * out + s[1];
      s[1] = q.b2 * x - q.a2 * out;
      x = out;
    }
    return x;
  }

 private:
  static constexpr int kMaxSections = 5;  // order 10
  std::array<Biquad, kMaxSections> sections_;
  std::array<std::array<double, 2>, kMaxSections> state_{};
  int count_ = 0;
};

/// Runs the filter forward and backward (zero phase, magnitude squared), with the ends
/// extended by odd reflection to avoid start-up transients. The reflection pivots on the end
/// samples, so noise on the very first and last samples still shows within a few time
/// constants of the ends. Needs at least 2 samples.
std::vector<double> FilterZeroPhase(const LowPassDesign& design, const std::vector<double>& x);

}  // namespace lunarnav::telemetry
