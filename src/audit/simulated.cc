// The audit of simulated data in memory (simulated.h): the simulator on a worker thread, a bounded
// queue of samples, a stream::Source that the engine reads on the caller's thread.
#include <boresight/audit/simulated.h>
#include <boresight/io/lcm_log.h>
#include <boresight/model/orbit_context.h>
#include <boresight/sim/output.h>
#include <boresight/sim/simulator.h>
#include <boresight/sim/truth.h>
#include <boresight/stream/engine.h>

#include <chrono>
#include <condition_variable>
#include <deque>
#include <exception>
#include <mutex>
#include <thread>

namespace boresight::audit {

bool pipelineConfigFor(const sim::Scenario& sc, const core::PipelineConfig& base, core::PipelineConfig& out,
                       std::string* error) {
  auto fail = [&](const std::string& why) {
    if (error) *error = sc.file + ": " + why;
    return false;
  };
  if (sc.heads.empty()) return fail("no heads");
  if (sc.heads.size() > static_cast<std::size_t>(core::kMaxHeads))
    return fail(std::to_string(sc.heads.size()) + " heads; the core takes at most " + std::to_string(core::kMaxHeads));
  for (const auto& h : sc.heads)
    if (h.rate_hz != sc.heads.front().rate_hz)
      return fail("heads of different rates (" + std::to_string(h.rate_hz) + " Hz and " +
                  std::to_string(sc.heads.front().rate_hz) + " Hz): the core fuses head epochs of one rate");
  out = base;
  out.heads.n_heads = static_cast<int>(sc.heads.size());
  for (std::size_t k = 0; k < sc.heads.size(); ++k)
    out.heads.head[k] = sc.heads[k].core();  // nominal q_Si_B (QSA1B), boresight, nominal noise model
  out.C_B_A = sc.acc.C_A_B.transpose();      // nominal: acc_misalignment is an effect
  out.crn_attitude.fs_hz = sc.heads.front().rate_hz;
  out.crn_acc.fs_hz = sc.acc.rate_hz;
  return true;
}

Truth truthOf(const sim::Simulator& s) {
  Truth t;
  t.effects = s.scenario().effects;
  for (const auto& h : s.heads()) t.mounting_error_rad[h.config().id] = h.config().mounting_error_rad;
  return t;
}

namespace {

/// One hand-over from the simulator: an input sample of the core or an orbit sample.
struct Item {
  bool orbit = false;
  stream::Sample s;
  model::OrbitSample o;
};
using Batch = std::vector<Item>;

/// The queue between the simulator thread and the engine's thread.
struct Queue {
  std::size_t batch_size = 1024, max_batches = 8;
  std::mutex m;
  std::condition_variable cv;
  std::deque<Batch> full;
  std::vector<Batch> spare;
  bool finished = false;  ///< the producer has pushed its last batch
  bool cancel = false;    ///< the consumer has gone: the producer stops
  std::string error;      ///< the producer failed (finished is set too)

  /// Producer: hands a batch over, waiting while the queue is full. False when cancelled.
  bool push(Batch& b) {
    std::unique_lock<std::mutex> l(m);
    cv.wait(l, [&] { return cancel || full.size() < max_batches; });
    if (cancel) return false;
    full.push_back(std::move(b));
    if (!spare.empty()) {
      b = std::move(spare.back());
      spare.pop_back();
    } else {
      b = Batch{};
    }
    b.clear();
    b.reserve(batch_size);
    cv.notify_all();
    return true;
  }
  void finish(const std::string& err) {
    std::lock_guard<std::mutex> l(m);
    finished = true;
    error = err;
    cv.notify_all();
  }
  /// Consumer: the next batch (returns the used one for reuse); false at the end.
  bool pop(Batch& b) {
    std::unique_lock<std::mutex> l(m);
    if (b.capacity() > 0) {
      b.clear();
      spare.push_back(std::move(b));
      b = Batch{};
    }
    cv.wait(l, [&] { return !full.empty() || finished; });
    if (full.empty()) return false;
    b = std::move(full.front());
    full.pop_front();
    cv.notify_all();
    return true;
  }
};

struct Cancelled {};

/// The simulator's sink on the worker thread: samples as the Level-1 sources make them from the
/// simulator's records (sim/output.h), collected into batches.
class QueueSink final : public sim::SimSink {
 public:
  QueueSink(Queue& q, char satellite) : q_(q), sat_(satellite) { b_.reserve(q.batch_size); }
  void head(const sim::HeadSampleOut& h) override {
    if (h.blind) return;  // a blinded head delivers nothing (as Level1Sink)
    const io::Sca1aRecord r = sim::toSca1a(h, sat_);
    Item& it = add();
    it.s.kind = stream::Sample::Kind::kHead;  // as stream::Sca1aSource
    it.s.t = r.t;
    it.s.head_id = r.head;
    it.s.q_I_S = quatFromScalarFirst(r.q);
    it.s.star_count = r.nstars;
    it.s.flags = 1;
    commit();
  }
  void accel(const sim::AccSampleOut& a) override {
    const io::AccelSample m = io::accelFromAcc1a(sim::toAcc1a(a, sat_), 0);  // as stream::Acc1aSource
    if (!(m.flags & 1)) return;  // no angular acceleration: the file source rejects it
    Item& it = add();
    it.s.kind = stream::Sample::Kind::kAccel;
    it.s.t = m.utime;
    it.s.a_A = Vec3(m.ang_accel[0], m.ang_accel[1], m.ang_accel[2]);
    it.s.lin_A = Vec3(m.lin_accel[0], m.lin_accel[1], m.lin_accel[2]);
    it.s.flags = m.flags;
    commit();
  }
  void orbit(const sim::OrbitSampleOut& o) override {
    model::OrbitSample os;
    if (!model::orbitSampleFromInertial(o.t, o.r_I, o.v_I, os)) return;
    Item& it = add();
    it.orbit = true;
    it.o = os;
    commit();
  }
  void flush() {
    if (!b_.empty() && !q_.push(b_)) throw Cancelled{};
  }

 private:
  Item& add() {
    b_.emplace_back();
    return b_.back();
  }
  void commit() {
    if (b_.size() >= q_.batch_size && !q_.push(b_)) throw Cancelled{};
  }
  Queue& q_;
  char sat_;
  Batch b_;
};

/// The engine's source: samples from the queue; orbit samples go to the Collector as they pass.
class QueueSource final : public stream::Source {
 public:
  QueueSource(Queue& q, const std::function<void(const model::OrbitSample&)>& orbit, std::uint64_t& orbit_count)
      : q_(q), orbit_(orbit), orbits_(orbit_count) {}
  Next next(stream::Sample& out, stream::Reject&) override {
    for (;;) {
      if (pos_ >= b_.size()) {
        pos_ = 0;
        if (!q_.pop(b_)) {
          std::lock_guard<std::mutex> l(q_.m);
          error_ = q_.error;
          return error_.empty() ? Next::kEnd : Next::kError;
        }
        continue;
      }
      const Item& it = b_[pos_++];
      if (it.orbit) {
        if (orbit_) orbit_(it.o);
        ++orbits_;
        continue;
      }
      out = it.s;
      return Next::kSample;
    }
  }
  const std::string& name() const override { return name_; }
  std::string error() const override { return error_; }

 private:
  Queue& q_;
  const std::function<void(const model::OrbitSample&)>& orbit_;
  std::uint64_t& orbits_;
  Batch b_;
  std::size_t pos_ = 0;
  std::string name_ = "simulator", error_;
};

}  // namespace

SimulatedRun feedSimulated(const sim::Scenario& sc, const SimulatedOptions& opt, const core::PipelineConfig& cfg,
                           stream::InputObserver* observer, stream::RowSink* sink,
                           const std::function<void(const model::OrbitSample&)>& orbit) {
  SimulatedRun run;
  const auto t0 = std::chrono::steady_clock::now();
  run.config = cfg;
  std::string err;
  auto sim = std::make_unique<sim::Simulator>();
  if (!sim->init(sc, opt.seed, opt.duration_s, &err)) {
    run.error = "simulator: " + err;
    return run;
  }
  run.truth = truthOf(*sim);
  stream::Engine engine;
  if (!engine.configure(cfg, &err)) {
    run.error = "core: " + err;
    return run;
  }
  Queue q;
  q.batch_size = opt.batch_size < 1 ? 1 : opt.batch_size;
  q.max_batches = opt.queue_batches < 1 ? 1 : opt.queue_batches;
  engine.addSource(std::make_unique<QueueSource>(q, orbit, run.orbit_samples));
  if (observer) engine.addObserver(observer);
  if (sink) engine.addSink(sink);

  bool to_end = false;
  std::thread producer([&q, &sim, &to_end, sat = sc.satellite] {
    std::string perr;
    try {
      QueueSink qs(q, sat);
      sim->run(qs);
      to_end = true;  // the whole span was simulated (a stopped consumer ends it inside run())
      qs.flush();
    } catch (const Cancelled&) {
      // the consumer has gone
    } catch (const std::exception& e) {
      perr = std::string("simulator: ") + e.what();
    }
    q.finish(perr);
  });
  const stream::Engine::Result r = engine.run();
  {
    std::lock_guard<std::mutex> l(q.m);
    q.cancel = true;
  }
  q.cv.notify_all();
  producer.join();

  run.simulated_to_end = to_end;
  run.counters = engine.counters();
  run.epochs = engine.epochs();
  run.rows = engine.rows();
  if (r != stream::Engine::Result::kDone) {
    run.error = "engine: " + (engine.error().empty() ? std::string("did not finish") : engine.error());
    return run;
  }
  run.collect_wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  run.ok = true;
  return run;
}

SimulatedRun collectSimulated(const sim::Scenario& sc, const SimulatedOptions& opt, Collector& c) {
  SimulatedRun run;
  std::string err;
  if (!pipelineConfigFor(sc, opt.base, run.config, &err)) {
    run.error = err;
    return run;
  }
  if (!c.configure(run.config, opt.audit, &err)) {
    run.error = err;
    return run;
  }
  return feedSimulated(sc, opt, run.config, &c, &c, [&c](const model::OrbitSample& o) { c.addOrbit(o); });
}

SimulatedAudit auditSimulated(const sim::Scenario& sc, const SimulatedOptions& opt) {
  SimulatedAudit a;
  Collector c;
  a.run = collectSimulated(sc, opt, c);
  if (!a.run.ok) return a;
  const auto t0 = std::chrono::steady_clock::now();
  a.result = analyse(c, opt.audit, opt.compare_truth ? &a.run.truth : nullptr);
  a.analyse_wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return a;
}

bool readTruthFile(const std::string& path, Truth& out, std::string* error) {
  out = Truth{};
  sim::TruthFile tf;
  if (!sim::readTruthYaml(path, tf, error)) return false;
  out.effects = tf.effects;
  for (const auto& h : tf.heads) out.mounting_error_rad[h.config.id] = h.config.mounting_error_rad;
  return true;
}

}  // namespace boresight::audit
