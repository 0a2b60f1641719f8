// The one time loop (Simulation::run): observers in order at every sample, the loop ended by
// an observer, and a stop through the attention flag that, run again from the next sample,
// continues bit for bit.
#include <gtest/gtest.h>

#include <atomic>
#include <string>
#include <utility>
#include <vector>

#include "driver/run.hpp"
#include "driver/simulation.hpp"

namespace jamflow {
namespace {

RunSpec small_spec(const std::string& integrator) {
  const std::string text =
      "[system]\nN = 64\nphi = 0.7\nseed = 5\n[ensemble]\nkind = \"constant_pressure\"\n"
      "pressure = 1e-3\nxi_V = 1e-2\n[shear]\nrate = 1e-2\n[integrator]\n" +
      integrator + "\n[run]\nt_eq = 0.0\nt_av = 10.0\nsample_every = 0.5\nthreads = 1\n";
  return parse_run_spec(Scene::parse(text, "loop.toml"));
}

// Records what the loop asked of it; ends the loop before sample `last + 1`; asks for a stop
// at sample `stop_at` (raising the attention flag) and stops when it attends.
struct Probe final : LoopObserver {
  Probe(std::string n, std::vector<std::string>* l) : name(std::move(n)), log(l) {}
  std::string name;
  std::vector<std::string>* log;
  long long last = 0, stop_at = -1;
  std::atomic<bool>* flag = nullptr;
  int attended = 0;
  bool proceed(Simulation&, long long k) override {
    log->push_back(name + " proceed " + std::to_string(k));
    return k <= last;
  }
  void sampled(Simulation& sim, long long k, double t) override {
    log->push_back(name + " sampled " + std::to_string(k));
    EXPECT_EQ(t, double(k) * 0.5);
    EXPECT_EQ(sim.time(), t);
    if (k == stop_at && flag)
      flag->store(true);
  }
  bool attend(Simulation&) override {
    ++attended;
    return true;
  }
};

TEST(Simulation, LoopCallsObserversInOrderUntilOneEndsIt) {
  const RunSpec spec = small_spec("kind = \"euler\"\ndt = 0.1");
  Simulation sim(spec, spec.seed);
  std::vector<std::string> log;
  Probe a("a", &log), b("b", &log);
  a.last = 3;
  b.last = 100;
  EXPECT_TRUE(sim.run(0.5, 1, {&a, &b}));
  EXPECT_EQ(sim.time(), 1.5);
  const std::vector<std::string> expected = {
      "a proceed 1", "b proceed 1", "a sampled 1", "b sampled 1", "a proceed 2",
      "b proceed 2", "a sampled 2", "b sampled 2", "a proceed 3", "b proceed 3",
      "a sampled 3", "b sampled 3", "a proceed 4"};
  EXPECT_EQ(log, expected);
  EXPECT_EQ(a.attended, 0);
}

// Stopped through the flag after a sample, then run again from the next sample: the same bits
// as a loop never stopped, for a fixed-step and an adaptive integrator.
TEST(Simulation, StoppedLoopContinuesBitForBit) {
  for (const std::string integrator :
       {"kind = \"euler\"\ndt = 0.1", "kind = \"respa\"\ndt = 0.5\ninner_scheme = \"heun\"",
        "kind = \"rkc\""}) {
    SCOPED_TRACE(integrator);
    const RunSpec spec = small_spec(integrator);
    std::vector<std::string> log;
    Simulation whole(spec, spec.seed);
    Probe all("all", &log);
    all.last = 12;
    ASSERT_TRUE(whole.run(0.5, 1, {&all}));

    Simulation parts(spec, spec.seed);
    std::atomic<bool> flag{false};
    Probe first("first", &log);
    first.last = 12;
    first.stop_at = 5;
    first.flag = &flag;
    EXPECT_FALSE(parts.run(0.5, 1, {&first}, &flag));
    EXPECT_EQ(first.attended, 1);
    EXPECT_FALSE(flag.load());  // the loop lowered it before attending
    EXPECT_EQ(parts.time(), 2.5);
    Probe rest("rest", &log);
    rest.last = 12;
    EXPECT_TRUE(parts.run(0.5, 6, {&rest}, &flag));

    EXPECT_EQ(parts.model().state().time, whole.model().state().time);
    EXPECT_EQ(parts.model().state().pos, whole.model().state().pos);
    EXPECT_EQ(parts.model().state().box.lx, whole.model().state().box.lx);
    EXPECT_EQ(parts.model().state().box.strain, whole.model().state().box.strain);
  }
}

}  // namespace
}  // namespace jamflow
