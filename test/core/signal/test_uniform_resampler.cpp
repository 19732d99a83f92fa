#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "die_cushion_ident/core/signal/uniform_resampler.h"

using namespace die_cushion_ident;

namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Feeds all three streams at `rate` Hz from t0 to t1 with linear signals; returns the grid samples.
std::vector<GridSample> feedLinear(UniformResampler& r, double t0, double t1, double rate,
                                   double offset = 0.0) {
  std::vector<GridSample> out;
  for (double t = t0; t < t1; t += 1.0 / rate) {
    r.push(InputStream::kPressure, {t, 1e6 + 1e7 * t, kNaN}, &out);
    r.push(InputStream::kPosition, {t + offset, 0.1 * (t + offset), 0.1}, &out);
    r.push(InputStream::kValve, {t + 2 * offset, 5.0 * (t + 2 * offset), 0.5 * (t + 2 * offset)}, &out);
  }
  return out;
}
// Pressure and position at rest at `t`; the valve message (voltage, spool) only when `valve` is set.
void pushAtRest(UniformResampler& r, double t, bool valve, double voltage, double spool,
                std::vector<GridSample>* out) {
  r.push(InputStream::kPressure, {t, 50e5, kNaN}, out);
  r.push(InputStream::kPosition, {t, 0.1, 0.0}, out);
  if (valve) r.push(InputStream::kValve, {t, voltage, spool}, out);
}

}  // namespace

TEST(UniformResampler, RejectsInvalidConfiguration) {
  UniformResampler::Config c;
  c.sample_period = 0.0;
  EXPECT_THROW(UniformResampler{c}, std::invalid_argument);
  c = {};
  c.max_gap = c.sample_period;
  EXPECT_THROW(UniformResampler{c}, std::invalid_argument);
  c = {};
  c.restart_jump = c.stale_timeout;
  EXPECT_THROW(UniformResampler{c}, std::invalid_argument);
}

TEST(UniformResampler, InterpolatesLinearSignalsExactlyOnAnAlignedGrid) {
  UniformResampler r({});
  const auto out = feedLinear(r, 0.0, 1.0, 1000.0, 0.0003);
  ASSERT_GT(out.size(), 490u);
  for (std::size_t i = 0; i < out.size(); ++i) {
    const GridSample& g = out[i];
    EXPECT_NEAR(std::remainder(g.t, 0.002), 0.0, 1e-12) << "grid points sit on multiples of the period";
    if (i > 0) {
      EXPECT_NEAR(g.t - out[i - 1].t, 0.002, 1e-12);
    }
    EXPECT_TRUE(g.complete);
    // Exact up to the channels' single-precision storage (one part in 1.7e7; the interpolation itself runs
    // in double).
    const auto exact = [](double value) { return 6e-8 * std::abs(value) + 1e-12; };
    EXPECT_NEAR(g.p, 1e6 + 1e7 * g.t, exact(1e6 + 1e7 * g.t));
    EXPECT_NEAR(g.x, 0.1 * g.t, exact(0.1 * g.t));
    EXPECT_NEAR(g.v, 0.1, exact(0.1));
    // The valve voltage is held from its stamp on: the value of the last message at or before t.
    EXPECT_LE(g.u, 5.0 * g.t + exact(5.0 * g.t) + 1e-9);
    EXPECT_GE(g.u, 5.0 * (g.t - 1e-3) - exact(5.0 * g.t) - 1e-9);
    EXPECT_NEAR(g.y, 0.5 * g.t, exact(0.5 * g.t) + 1e-9);
  }
  EXPECT_NEAR(r.health(InputStream::kPressure).rate(), 1000.0, 1e-6);
}

TEST(UniformResampler, CountsAndRejectsNonFiniteDuplicateAndOutOfOrderMessages) {
  UniformResampler r({});
  std::vector<GridSample> out;
  EXPECT_EQ(r.push(InputStream::kPressure, {0.010, 1.0, kNaN}, &out),
            UniformResampler::PushResult::kAccepted);
  EXPECT_EQ(r.push(InputStream::kPressure, {0.010, 2.0, kNaN}, &out),
            UniformResampler::PushResult::kDuplicate);
  EXPECT_EQ(r.push(InputStream::kPressure, {0.009, 2.0, kNaN}, &out),
            UniformResampler::PushResult::kOutOfOrder);
  EXPECT_EQ(r.push(InputStream::kPressure, {0.011, kNaN, kNaN}, &out),
            UniformResampler::PushResult::kNonFinite);
  EXPECT_EQ(r.push(InputStream::kPressure, {kNaN, 1.0, kNaN}, &out),
            UniformResampler::PushResult::kNonFinite);
  EXPECT_EQ(r.push(InputStream::kPressure, {std::numeric_limits<double>::infinity(), 1.0, kNaN}, &out),
            UniformResampler::PushResult::kNonFinite);
  const auto& h = r.health(InputStream::kPressure);
  EXPECT_EQ(h.received, 6u);
  EXPECT_EQ(h.accepted, 1u);
  EXPECT_EQ(h.duplicates, 1u);
  EXPECT_EQ(h.out_of_order, 1u);
  EXPECT_EQ(h.non_finite, 3u);
}

TEST(UniformResampler, DoesNotInterpolateAcrossGaps) {
  UniformResampler r({});
  std::vector<GridSample> out = feedLinear(r, 0.0, 0.2, 1000.0);
  // Pressure falls silent for 50 ms (> max_gap of 20 ms, < stale timeout), the others keep going.
  for (double t = 0.2; t < 0.4; t += 0.001) {
    if (t < 0.25 || t > 0.3) r.push(InputStream::kPressure, {t, 1.0, kNaN}, &out);
    r.push(InputStream::kPosition, {t, 0.0, 0.0}, &out);
    r.push(InputStream::kValve, {t, 0.0, 0.0}, &out);
  }
  int incomplete = 0;
  for (const auto& g : out) {
    if (g.t > 0.251 && g.t < 0.299) {
      EXPECT_FALSE(g.complete) << "t = " << g.t;
      EXPECT_TRUE(std::isnan(g.p));
      ++incomplete;
    }
  }
  EXPECT_GE(incomplete, 20);
  EXPECT_EQ(r.health(InputStream::kPressure).gaps, 1u);
}

TEST(UniformResampler, ASilentStreamIsReportedStaleAndDoesNotBlockTheOthers) {
  UniformResampler r({});
  std::vector<GridSample> out;
  for (double t = 0.0; t < 1.0; t += 0.001) {
    r.push(InputStream::kPressure, {t, 1e6, kNaN}, &out);
    r.push(InputStream::kPosition, {t, 0.0, kNaN}, &out);  // the valve topic never arrives
  }
  EXPECT_TRUE(r.health(InputStream::kValve).stale);
  ASSERT_GT(out.size(), 300u) << "the grid must advance without the silent topic";
  for (const auto& g : out) {
    EXPECT_FALSE(g.complete);
    EXPECT_TRUE(std::isnan(g.u));
    EXPECT_DOUBLE_EQ(g.p, 1e6);
  }
}

TEST(UniformResampler, ABackwardJumpRestartsTheGrid) {
  UniformResampler::Config config;
  config.sample_period = 0.001;
  UniformResampler r(config);
  // The position at 500 Hz on the 1 ms grid: the old base's last two points wait for its next message.
  std::vector<GridSample> first;
  for (int k = 0; k < 1000; ++k) {
    const double t = 100.0 + 1e-3 * k;
    r.push(InputStream::kPressure, {t, 1e6, kNaN}, &first);
    if (k % 2 == 0) r.push(InputStream::kPosition, {t, 0.1 * t, 0.1}, &first);
    r.push(InputStream::kValve, {t, 1.0, 0.1}, &first);
  }
  ASSERT_FALSE(first.empty());
  std::vector<GridSample> out;
  // One message on the new time base is held; the other topics confirm the jump (a bag played again).
  EXPECT_EQ(r.push(InputStream::kPressure, {10.0, 1.0, kNaN}, &out), UniformResampler::PushResult::kHeld);
  EXPECT_EQ(r.push(InputStream::kPosition, {10.0, 1.0, kNaN}, &out), UniformResampler::PushResult::kHeld);
  EXPECT_EQ(r.push(InputStream::kValve, {10.0, 1.0, kNaN}, &out), UniformResampler::PushResult::kRestarted);
  auto second = feedLinear(r, 10.001, 11.0, 1000.0);
  ASSERT_FALSE(second.empty());
  // The old base's last points (those that waited for the position's next message) come first.
  for (const GridSample& g : out) {
    if (g.t > 50.0) EXPECT_FALSE(g.discontinuity);
  }
  out.insert(out.end(), second.begin(), second.end());
  const auto restarted = std::find_if(out.begin(), out.end(), [](const GridSample& g) { return g.t < 50.0; });
  ASSERT_NE(restarted, out.end());
  EXPECT_TRUE(restarted->discontinuity) << "downstream filters must be told to start over";
  EXPECT_LT(restarted->t, 10.01);
  EXPECT_EQ(r.restarts(), 1u);
  // Nothing of the old base is lost: its grid reaches the last messages' stamp.
  double last_old = 0.0;
  for (const GridSample& g : first) last_old = std::max(last_old, g.t);
  for (const GridSample& g : out) {
    if (g.t > 50.0) last_old = std::max(last_old, g.t);
  }
  EXPECT_GT(last_old, 100.998 - 1e-6) << "the points that waited for the position's next message";
}

TEST(UniformResampler, ALongSilenceOfAllStreamsJumpsTheGridInsteadOfFillingIt) {
  UniformResampler r({});
  auto a = feedLinear(r, 0.0, 1.0, 1000.0);
  auto b = feedLinear(r, 3600.0, 3601.0, 1000.0);  // an hour later
  EXPECT_LT(b.size(), 600u) << "an hour of silence must not produce 1.8 million empty samples";
  ASSERT_FALSE(b.empty());
  EXPECT_TRUE(b.front().discontinuity);
}

TEST(UniformResampler, MeasuresJitter) {
  UniformResampler r({});
  std::vector<GridSample> out;
  for (int k = 0; k < 2000; ++k) {
    const double t = k * 0.001 + ((k % 2) ? 0.0001 : 0.0);
    r.push(InputStream::kPressure, {t, 0.0, kNaN}, &out);
  }
  const auto& h = r.health(InputStream::kPressure);
  EXPECT_NEAR(h.mean_interval, 0.001, 1e-7);
  EXPECT_NEAR(h.interval_std, 0.0001, 2e-6) << "alternating 0.9/1.1 ms intervals have a 0.1 ms spread";
  EXPECT_NEAR(h.max_interval, 0.0011, 1e-9);
}

TEST(UniformResampler, FlushEmitsWhatTheStreamsCover) {
  UniformResampler r({});
  auto out = feedLinear(r, 0.0, 0.1, 1000.0, 0.0004);
  const std::size_t before = out.size();
  r.flush(&out);
  EXPECT_GE(out.size(), before);
  EXPECT_LE(out.back().t, 0.1);
}

// A single wild stamp must not restart the identification; a clock that jumps for one topic only is that
// topic's fault, not the others' (hostile-input review: one message 100 s in the past, or 1000 s ahead,
// restarted everything and blamed the healthy topics).
TEST(UniformResampler, ASingleWildStampIsRejectedNotARestart) {
  for (const double wild : {-100.0, 1000.0}) {
    UniformResampler r({});
    auto before = feedLinear(r, 100.0, 101.0, 1000.0);
    std::vector<GridSample> out;
    EXPECT_EQ(r.push(InputStream::kPressure, {101.0 + wild, 1.0, kNaN}, &out),
              UniformResampler::PushResult::kHeld);
    auto after = feedLinear(r, 101.0, 102.0, 1000.0);
    EXPECT_EQ(r.restarts(), 0u) << wild;
    EXPECT_EQ(r.health(InputStream::kPressure).wild_stamps, 1u) << wild;
    EXPECT_NEAR(r.health(InputStream::kPressure).last_wild_offset, wild, 0.01);
    ASSERT_GT(after.size(), 400u) << "the grid goes on";
    for (const auto& g : after) EXPECT_FALSE(g.discontinuity);
    EXPECT_NEAR(r.health(InputStream::kPressure).rate(), 1000.0, 1.0) << "the wild stamp is no interval";
  }
}

TEST(UniformResampler, OneTopicStampedAheadForSecondsIsRejectedAndNamed) {
  UniformResampler r({});
  feedLinear(r, 100.0, 101.0, 1000.0);
  std::vector<GridSample> out;
  for (double t = 101.0; t < 106.0; t += 0.001) {
    r.push(InputStream::kPressure, {t, 1e6, kNaN}, &out);
    r.push(InputStream::kPosition, {t + 1000.0, 0.1, 0.1}, &out);  // its clock is 1000 s ahead
    r.push(InputStream::kValve, {t, 5.0, 0.5}, &out);
  }
  EXPECT_EQ(r.restarts(), 0u);
  EXPECT_GT(r.health(InputStream::kPosition).wild_stamps, 4900u);
  EXPECT_EQ(r.health(InputStream::kPressure).wild_stamps, 0u);
  EXPECT_TRUE(r.health(InputStream::kPosition).stale);
  EXPECT_FALSE(r.health(InputStream::kPressure).stale) << "the healthy topics are not blamed";
  EXPECT_GT(out.size(), 2000u) << "the grid goes on with the healthy topics";
  const auto back = feedLinear(r, 106.0, 107.0, 1000.0);  // the clock is right again
  EXPECT_FALSE(r.health(InputStream::kPosition).stale);
  ASSERT_FALSE(back.empty());
  EXPECT_TRUE(back.back().complete);
}

TEST(UniformResampler, APauseOfAllTopicsJumpsTheGridWithoutARestart) {
  UniformResampler r({});
  feedLinear(r, 0.0, 1.0, 1000.0);
  const auto after = feedLinear(r, 30.0, 31.0, 1000.0);
  EXPECT_EQ(r.restarts(), 0u);
  ASSERT_FALSE(after.empty());
  EXPECT_TRUE(after.front().discontinuity);
  EXPECT_NEAR(r.health(InputStream::kPressure).rate(), 1000.0, 1.0) << "a pause is a gap, not an interval";
  EXPECT_EQ(r.health(InputStream::kPressure).wild_stamps, 0u);
}

TEST(UniformResampler, ImplausibleValuesAreRejectedLikeNonFiniteOnes) {
  UniformResampler::Config c;
  c.plausible[0].min_first = -2e5;
  c.plausible[0].max_first = 240e5;
  c.plausible[1].max_abs_second = 10.0;
  UniformResampler r(c);
  std::vector<GridSample> out;
  EXPECT_EQ(r.push(InputStream::kPressure, {0.0, 1e300, kNaN}, &out), UniformResampler::PushResult::kImplausible);
  EXPECT_EQ(r.push(InputStream::kPressure, {0.0, 1e9, kNaN}, &out), UniformResampler::PushResult::kImplausible);
  EXPECT_EQ(r.push(InputStream::kPressure, {0.0, -1e6, kNaN}, &out), UniformResampler::PushResult::kImplausible);
  EXPECT_EQ(r.push(InputStream::kPosition, {0.0, 0.1, 1e300}, &out), UniformResampler::PushResult::kImplausible);
  EXPECT_EQ(r.push(InputStream::kPosition, {0.0, 0.1, kNaN}, &out), UniformResampler::PushResult::kAccepted)
      << "an unmeasured velocity is no implausible one";
  EXPECT_EQ(r.push(InputStream::kPressure, {0.0, 100e5, kNaN}, &out), UniformResampler::PushResult::kAccepted);
  EXPECT_EQ(r.health(InputStream::kPressure).implausible, 3u);
  EXPECT_EQ(r.health(InputStream::kPosition).implausible, 1u);
}

// A controller dithering the spool at its own 1 kHz around 0 crosses the valve's kink between the points of
// a 2 ms grid: the grid carries the means of the drain and supply parts over each interval, from the line
// through the valve messages, next to y at the point.
TEST(UniformResampler, CarriesTheSpoolsDrainAndSupplyPartsOverEachInterval) {
  UniformResampler r({});
  std::vector<GridSample> out;
  for (int k = 0; k < 200; ++k) {
    const double t = 1e-3 * k;
    pushAtRest(r, t, true, 0.1, k % 2 == 0 ? -0.2 : 0.2, &out);  // -0.2 on the grid's points
  }
  ASSERT_GT(out.size(), 90u);
  for (std::size_t i = 1; i < out.size(); ++i) {
    // Over [t - 1 ms, t + 1 ms] the line runs +0.2 -> -0.2 -> +0.2: a quarter of the time at a mean 0.1
    // above 0, the same below.
    EXPECT_NEAR(out[i].y, -0.2, 1e-7);
    EXPECT_NEAR(out[i].y_drain, 0.05, 1e-7) << out[i].t;
    EXPECT_NEAR(out[i].y_supply, -0.05, 1e-7) << out[i].t;
  }
  // A spool that stays on one side: its parts are its interval mean and 0.
  UniformResampler ramp({});
  const auto lines = feedLinear(ramp, 0.0, 0.2, 1000.0);
  for (std::size_t i = 1; i + 1 < lines.size(); ++i) {
    EXPECT_NEAR(lines[i].y_drain, 0.5 * lines[i].t, 1e-7);
    EXPECT_EQ(lines[i].y_supply, 0.0f);
  }
  // Not measured: NaN parts, as y.
  UniformResampler unmeasured({});
  std::vector<GridSample> none;
  for (int k = 0; k < 20; ++k) {
    const double t = 1e-3 * k;
    pushAtRest(unmeasured, t, true, 0.1, kNaN, &none);
  }
  ASSERT_FALSE(none.empty());
  for (const auto& g : none) EXPECT_TRUE(std::isnan(g.y_drain) && std::isnan(g.y_supply));
}

// A 1 kHz controller on the 2 ms grid: u is the command in force at the grid point, u_mean the mean of the
// held commands over [t - 1 ms, t + 1 ms], the one the valve model needs to see the others too. Measured
// spool or not, it is the command's; a gap in the valve stream leaves it NaN.
TEST(UniformResampler, CarriesTheHeldCommandsMeanOverEachInterval) {
  for (const double spool : {0.1, kNaN}) {
    UniformResampler r({});
    std::vector<GridSample> out;
    for (int k = 0; k < 200; ++k) {
      const double t = 1e-3 * k;
      pushAtRest(r, t, true, k % 2 == 0 ? 1.0 : 3.0, spool, &out);  // 1 V on the grid's points
    }
    ASSERT_GT(out.size(), 90u);
    for (std::size_t i = 1; i < out.size(); ++i) {
      EXPECT_EQ(out[i].u, 1.0f);
      // [t - 1 ms, t): 3 V; [t, t + 1 ms): 1 V.
      EXPECT_NEAR(out[i].u_mean, 2.0, 1e-6) << out[i].t;
    }
  }
  // Commands at 250 Hz, held 4 ms: the mean over the interval straddling a change weighs each by its time.
  UniformResampler slow({});
  std::vector<GridSample> out;
  for (int k = 0; k < 200; ++k) {
    const double t = 1e-3 * k;
    pushAtRest(slow, t, k % 4 == 0, static_cast<double>(k / 4), 0.1, &out);
  }
  ASSERT_GT(out.size(), 40u);
  for (std::size_t i = 1; i + 2 < out.size(); ++i) {
    const double t = out[i].t;
    const double held = std::floor(t / 4e-3 + 1e-9);
    // Points at a change (t = 4 ms n) have half the interval on each command; the others sit inside one.
    const bool at_change = std::abs(t / 4e-3 - std::round(t / 4e-3)) < 1e-6;
    EXPECT_NEAR(out[i].u_mean, at_change ? held - 0.5 : held, 1e-5) << t;
  }
}

// The valve model's spool mean over the interval that ends at each grid point, [t - T, t], from the
// messages' exact stretch means (StreamSample::third_mean): exact where the messages fall on the grid, and
// exact for a quadratic spool where they are stamped 0.3 ms off it (the stretches cut at the grid's points
// are integrated along the quadratic through their ends with their mean). No mean where a stretch has none.
TEST(UniformResampler, CarriesTheValveModelsSpoolMeanOverEachInterval) {
  const auto spool = [](double t) { return 0.05 + 2.0 * t * t; };
  const auto integral = [](double t) { return 0.05 * t + 2.0 * t * t * t / 3.0; };
  for (const double offset : {0.0, 3e-4}) {
    SCOPED_TRACE(offset);
    UniformResampler::Config config;
    config.sample_period = 0.001;
    UniformResampler r(config);
    std::vector<GridSample> out;
    for (int k = 0; k < 300; ++k) {
      const double t = 1e-3 * k + offset;
      pushAtRest(r, 1e-3 * k, false, 0.0, 0.0, &out);
      StreamSample valve{t, 1.0, kNaN};
      valve.third = spool(t);
      // The first message has no stretch before it; one in the middle has none either.
      valve.third_mean = k == 0 || k == 150 ? kNaN : (integral(t) - integral(t - 1e-3)) / 1e-3;
      r.push(InputStream::kValve, valve, &out);
    }
    ASSERT_GT(out.size(), 250u);
    int checked = 0;
    for (const GridSample& g : out) {
      const double exact = (integral(g.t) - integral(g.t - 1e-3)) / 1e-3;
      const double missing_from = 0.149 + offset, missing_to = 0.150 + offset;  // the stretch without a mean
      if (g.t - 1e-3 < missing_to - 1e-9 && g.t > missing_from + 1e-9) {
        EXPECT_TRUE(std::isnan(g.y_model_mean)) << g.t;
        continue;
      }
      if (!std::isfinite(g.y_model)) continue;
      if (g.t < 2e-3 + offset) continue;  // before two messages
      EXPECT_NEAR(g.y_model_mean, exact, 1e-7) << g.t;
      ++checked;
    }
    EXPECT_GT(checked, 250);
  }
}

// The position and velocity between their messages are the cubic through the two messages each side: a
// uniformly accelerated stroke stamped 0.3 ms off the 1 ms grid is read exactly at the grid's points, where a
// line through two messages was off by w (1 - w) h^2 x'' / 2 (here 0.2 um: a few us of the velocity's
// timing at an impact, which biased the free run's bulk modulus by up to 1 %: doc/resolution.md).
TEST(UniformResampler, ReadsThePositionByACubicBetweenItsMessages) {
  const auto x = [](double t) { return 0.02 + 0.3 * t + 2.0 * t * t; };
  const auto v = [](double t) { return 0.3 + 4.0 * t; };
  UniformResampler::Config config;
  config.sample_period = 0.001;
  UniformResampler r(config);
  std::vector<GridSample> out;
  for (int k = 0; k < 200; ++k) {
    const double t = 1e-3 * k;
    r.push(InputStream::kPressure, {t, 50e5, kNaN}, &out);
    r.push(InputStream::kPosition, {t + 3e-4, x(t + 3e-4), v(t + 3e-4)}, &out);
    r.push(InputStream::kValve, {t, 1.0, 0.1}, &out);
  }
  r.flush(&out);
  ASSERT_GT(out.size(), 190u);
  double worst_x = 0.0, worst_v = 0.0;
  for (std::size_t i = 1; i + 1 < out.size(); ++i) {  // the first and last intervals have a one-sided cubic
    worst_x = std::max(worst_x, std::abs(out[i].x - x(out[i].t)));
    worst_v = std::max(worst_v, std::abs(out[i].v - v(out[i].t)));
  }
  EXPECT_LT(worst_x, 2e-8) << "m: the float's resolution at 0.16 m, where a line was 2.1e-7 off";
  EXPECT_LT(worst_v, 1e-6) << "m/s";
}

// The position's cubic needs the message after the grid point's bracket: the grid point waits for it (one
// message interval), and where the stream falls silent it is emitted with the chord once the stream is
// declared stale, or at the recording's end (flush): nothing is lost.
TEST(UniformResampler, ThePositionsCubicWaitsForTheNextMessageAndLosesNothing) {
  UniformResampler::Config config;
  config.sample_period = 0.001;
  UniformResampler r(config);
  std::vector<GridSample> out;
  for (int k = 0; k <= 12; ++k) {
    const double t = 1e-3 * k;
    r.push(InputStream::kPressure, {t, 50e5, kNaN}, &out);
    r.push(InputStream::kValve, {t, 1.0, 0.1}, &out);
    if (k <= 10) r.push(InputStream::kPosition, {t, 0.1, 0.0}, &out);
  }
  // The position's last message is at 10 ms: the point at 10 ms has no message after its bracket yet.
  ASSERT_FALSE(out.empty());
  EXPECT_NEAR(out.back().t, 0.009, 1e-9);
  r.push(InputStream::kPosition, {0.011, 0.1, 0.0}, &out);
  EXPECT_NEAR(out.back().t, 0.010, 1e-9);
  // The position falls silent; the others go on: past the stale timeout its last points come with the chord.
  for (int k = 13; k < 300; ++k) {
    const double t = 1e-3 * k;
    r.push(InputStream::kPressure, {t, 50e5, kNaN}, &out);
    r.push(InputStream::kValve, {t, 1.0, 0.1}, &out);
  }
  bool emitted_11ms = false;
  for (const GridSample& g : out) emitted_11ms |= std::abs(g.t - 0.011) < 1e-9 && std::isfinite(g.x);
  EXPECT_TRUE(emitted_11ms) << "the point at the silent position's last message";
  // At a recording's end: flush emits what the streams cover.
  UniformResampler ending(config);
  std::vector<GridSample> end;
  for (int k = 0; k <= 10; ++k) pushAtRest(ending, 1e-3 * k, true, 1.0, 0.1, &end);
  ending.flush(&end);
  EXPECT_NEAR(end.back().t, 0.010, 1e-9);
  EXPECT_TRUE(std::isfinite(end.back().x));
}

// A grid put on the position's messages (grid_phase): its points are k T + phase, the position is read
// where it was measured, and the pressure between its own messages by the cubic through four, which
// reproduces a parabola (a line through two missed its curvature: 0.25 of a period's squared curvature
// at the interval's middle).
TEST(UniformResampler, AGridOnThePositionsMessagesReadsThemWhereTheyWereMeasured) {
  UniformResampler::Config c;
  c.sample_period = 0.001;
  c.grid_phase = 0.0023;  // taken modulo the period: 0.3 ms
  UniformResampler r(c);
  const auto pressure = [](double t) { return 50e5 + 1e8 * (t - 0.5) * (t - 0.5); };
  const auto position = [](double t) { return 0.1 + 0.05 * std::sin(10.0 * t); };
  std::vector<GridSample> out;
  for (int i = 0; i < 1000; ++i) {
    const double t = 1e-3 * i;
    r.push(InputStream::kPressure, {t, pressure(t), kNaN}, &out);
    r.push(InputStream::kPosition, {t + 0.3e-3, position(t + 0.3e-3), 0.5 * std::cos(10.0 * (t + 0.3e-3))},
           &out);
    r.push(InputStream::kValve, {t, 1.0, 0.1}, &out);
  }
  r.flush(&out);
  ASSERT_GT(out.size(), 900u);
  for (std::size_t i = 2; i + 2 < out.size(); ++i) {
    const GridSample& g = out[i];
    ASSERT_NEAR(std::remainder(g.t - 0.3e-3, 0.001), 0.0, 1e-12) << "points at k T + phase";
    EXPECT_NEAR(g.x, position(g.t), 1e-6) << "the position's own message, in single precision";
    EXPECT_NEAR(g.p, pressure(g.t), 5.0) << "the parabola through the cubic, at " << g.t;
  }
  EXPECT_THROW(UniformResampler([] {
                 UniformResampler::Config bad;
                 bad.grid_phase = std::nan("");
                 return bad;
               }()),
               std::invalid_argument);
}
