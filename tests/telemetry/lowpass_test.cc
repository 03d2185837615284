#include "telemetry/lowpass.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

namespace lunarnav::telemetry {
namespace {

double Db(std::complex<double> h) { return 20.0 * std::log10(std::abs(h)); }

TEST(DesignLowPass, SecondOrderButterworthMatchesTheClosedForm) {
  // The bilinear-transform Butterworth biquad with pre-warping (e.g. the "Audio EQ Cookbook"
  // low-pass with Q = 1/sqrt(2)): K = tan(pi fc/fs), norm = 1/(1 + sqrt2 K + K^2).
  const double fc = 0.25, fs = 10.0;
  const LowPassDesign d = DesignLowPass(LowPassType::kButterworth, 2, fc, fs);
  ASSERT_EQ(d.sections.size(), 1u);
  const double k = std::tan(M_PI * fc / fs), norm = 1.0 / (1.0 + std::sqrt(2.0) * k + k * k);
  EXPECT_NEAR(d.sections[0].b0, k * k * norm, 1e-14);
  EXPECT_NEAR(d.sections[0].b1, 2 * k * k * norm, 1e-14);
  EXPECT_NEAR(d.sections[0].a1, 2 * (k * k - 1) * norm, 1e-14);
  EXPECT_NEAR(d.sections[0].a2, (1 - std::sqrt(2.0) * k + k * k) * norm, 1e-14);
}

TEST(DesignLowPass, IsThreeDecibelsDownAtTheCutoffWithUnitDcGain) {
  for (LowPassType type : {LowPassType::kButterworth, LowPassType::kBessel}) {
    for (int order = 1; order <= 8; ++order) {
      const LowPassDesign d = DesignLowPass(type, order, 0.25, 10.0);
      EXPECT_NEAR(std::abs(FrequencyResponse(d, 0.0)), 1.0, 1e-12) << ToString(type) << order;
      EXPECT_NEAR(Db(FrequencyResponse(d, 0.25)), -3.0103, 1e-3) << ToString(type) << order;
      EXPECT_LT(std::abs(FrequencyResponse(d, 4.99)), 1e-3) << ToString(type) << order;
    }
  }
}

TEST(BesselDelayNormalizedCutoff, MatchesTheClassicTable) {
  // -3 dB frequencies of the unit-delay Bessel prototypes (e.g. Zverev, Handbook of Filter
  // Synthesis; also scipy.signal.bessel's 'delay' vs 'mag' normalisations).
  EXPECT_NEAR(BesselDelayNormalizedCutoff(1), 1.0000, 1e-4);
  EXPECT_NEAR(BesselDelayNormalizedCutoff(2), 1.3617, 1e-4);
  EXPECT_NEAR(BesselDelayNormalizedCutoff(3), 1.7557, 1e-4);
  EXPECT_NEAR(BesselDelayNormalizedCutoff(4), 2.1139, 1e-4);
  EXPECT_NEAR(BesselDelayNormalizedCutoff(5), 2.4274, 1e-4);
}

TEST(FilterCausal, LagsARampByTheDocumentedDelay) {
  // A slow ramp comes out late by the DC group delay (the paper's "2-3 cycle delay").
  for (LowPassType type : {LowPassType::kButterworth, LowPassType::kBessel}) {
    const LowPassDesign d = DesignLowPass(type, 2, 0.25, 10.0);
    std::vector<double> ramp(2000);
    for (int i = 0; i < 2000; ++i) ramp[i] = 0.01 * i;
    const std::vector<double> y = FilterCausal(d, ramp);
    const double lag = (ramp[1500] - y[1500]) / 0.01;
    EXPECT_NEAR(lag, d.delay_samples, 1e-6) << ToString(type);
    EXPECT_GT(d.delay_samples, 1.0);
  }
}

TEST(FilterCausal, StartsInTheSteadyStateOfTheFirstSample) {
  const LowPassDesign d = DesignLowPass(LowPassType::kBessel, 4, 0.25, 10.0);
  const std::vector<double> y = FilterCausal(d, std::vector<double>(50, 137.0));
  for (double v : y) EXPECT_NEAR(v, 137.0, 1e-9);
}

// Sample by sample, the filter gives the numbers of the whole-array filter, every type and
// order (a cascade of up to four sections).
TEST(CausalLowPass, GivesTheNumbersOfFilterCausal) {
  std::vector<double> x(300);
  for (std::size_t k = 0; k < x.size(); ++k) x[k] = std::sin(0.05 * k) + 0.3 * std::cos(1.7 * k * k) + 5.0;
  for (LowPassType type : {LowPassType::kButterworth, LowPassType::kBessel}) {
    for (int order = 1; order <= 8; ++order) {
      const LowPassDesign d = DesignLowPass(type, order, 0.25, 10.0);
      const std::vector<double> expected = FilterCausal(d, x);
      CausalLowPass filter(d, x[0]);
      for (std::size_t k = 0; k < x.size(); ++k) {
        ASSERT_EQ(filter(x[k]), expected[k]) << ToString(type) << " order " << order << ", sample " << k;
      }
    }
  }
}

TEST(FilterZeroPhase, HasNoLagAndRemovesNoise) {
  const LowPassDesign d = DesignLowPass(LowPassType::kButterworth, 3, 0.25, 10.0);
  std::vector<double> x(1000), truth(1000);
  for (int i = 0; i < 1000; ++i) {
    truth[i] = std::sin(2 * M_PI * 0.02 * i / 10.0);               // 0.02 Hz at 10 Hz
    x[i] = truth[i] + 0.3 * std::sin(2 * M_PI * 3.0 * i / 10.0);     // 3 Hz interference
  }
  const std::vector<double> y = FilterZeroPhase(d, x);
  // Away from the ends (the odd reflection pivots on the end samples, noise included, so the
  // first and last ~10 time constants carry some of it).
  double worst = 0;
  for (int i = 100; i < 900; ++i) worst = std::max(worst, std::abs(y[i] - truth[i]));
  EXPECT_LT(worst, 2e-3);
}

TEST(DesignLowPass, RejectsImpossibleSettings) {
  EXPECT_THROW(DesignLowPass(LowPassType::kButterworth, 0, 0.25, 10), std::invalid_argument);
  EXPECT_THROW(DesignLowPass(LowPassType::kBessel, 9, 0.25, 10), std::invalid_argument);
  EXPECT_THROW(DesignLowPass(LowPassType::kButterworth, 2, 5.0, 10), std::invalid_argument);
  EXPECT_THROW(LowPassTypeFromString("chebyshev"), std::invalid_argument);
}

}  // namespace
}  // namespace lunarnav::telemetry
