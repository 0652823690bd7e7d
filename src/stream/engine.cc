// Engine: the replay loop (assembler -> core -> sinks).
#include <boresight/stream/engine.h>

#include <chrono>
#include <limits>

namespace boresight::stream {

Engine::Engine(const AssemblerConfig& acfg)
    : pipe_(std::make_unique<core::Pipeline>()),
      asm_(acfg),
      stars_(std::make_unique<core::StarEpoch>()) {}
Engine::~Engine() = default;

bool Engine::configure(const core::PipelineConfig& cfg, std::string* error) {
  core::Status st = pipe_->configure(cfg);
  configured_ = st == core::Status::kOk;
  heads_cfg_ = cfg.heads;
  if (!configured_ && error) *error = std::string("the core rejected the configuration: ") + core::statusName(st);
  return configured_;
}

bool orbitAngles(const Sample& s, model::OrbitSample& out) {
  if (model::orbitSampleFromRecord(s.t, s.orbit_frame, s.r_orbit, s.v_orbit, out)) return true;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  out = model::OrbitSample{};
  out.t = s.t;
  out.r_I = out.v_I = Vec3::Constant(nan);
  out.u_rad = out.u_rate_rad_s = out.beta_rad = nan;
  return false;
}

bool Engine::setThermalModel(const core::ThermalHarmonicModel& m, std::string* error) {
  const core::Status st = configured_ ? pipe_->setThermalModel(m) : core::Status::kNotConfigured;
  if (st != core::Status::kOk && error) *error = std::string("the core refused the thermal model: ") + core::statusName(st);
  return st == core::Status::kOk;
}

bool Engine::wantsOrbit() const {
  if (pipe_->thermal().configured()) return true;
  for (const InputObserver* o : observers_)
    if (o->wantsOrbit()) return true;
  return false;
}

void Engine::addSource(std::unique_ptr<Source> s) {
  asm_.addSource(s.get());
  sources_.push_back(std::move(s));
}

void Engine::addSink(RowSink* sink) { sinks_.push_back(sink); }

void Engine::addObserver(InputObserver* o) { observers_.push_back(o); }

core::Health Engine::health() const { return pipe_->health(); }

bool Engine::flushCore() {
  pipe_->flush();
  return drain();
}

namespace {
using Clock = std::chrono::steady_clock;
double nsSince(Clock::time_point t0) { return std::chrono::duration<double, std::nano>(Clock::now() - t0).count(); }
}  // namespace

bool Engine::drain() {
  core::PipelineRow r;
  while (pipe_->popRow(r)) {
    ++rows_;
    for (RowSink* s : sinks_)
      if (!s->write(r)) {
        error_ = s->error();
        return false;
      }
  }
  return true;
}

Engine::Result Engine::run() {
  if (!configured_) {
    error_ = "the engine is not configured";
    return Result::kError;
  }
  if (finished_) return Result::kDone;
  if (!begun_) {
    for (RowSink* s : sinks_)
      if (!s->begin(pipe_->config())) {
        error_ = s->error();
        return Result::kError;
      }
    begun_ = true;
  }
  core::HeadEpoch e;
  TimeUs t = 0;
  Vec3 a = Vec3::Zero();
  Sample* const orbit = wantsOrbit() ? &orbit_ : nullptr;
  for (;;) {
    switch (asm_.next(e, t, a, stars_.get(), orbit)) {
      case EpochAssembler::Out::kOrbit: {
        model::OrbitSample o;
        orbitAngles(orbit_, o);  // no orbit plane: NaN angles, which the core counts as non-finite
        ++orbit_samples_;
        const core::Status st = pipe_->stepOrbit(t, o.u_rad, o.u_rate_rad_s, o.beta_rad);
        for (InputObserver* ob : observers_)
          if (ob->wantsOrbit()) ob->onOrbit(o);
        if (hook_) hook_->afterStep(Sample::Kind::kOrbit, t, st, 0.0);
        break;
      }
      case EpochAssembler::Out::kStars: {
        ++star_epochs_;
        const Clock::time_point t0 = hook_ ? Clock::now() : Clock::time_point{};
        const core::Status st = pipe_->stepStars(*stars_);
        if (hook_) hook_->afterStep(Sample::Kind::kStar, stars_->t, st, nsSince(t0));
        if (st == core::Status::kOk) {
          ++star_solutions_;
          StarSolution sol;
          sol.wahba = pipe_->wahba().output();
          const core::FusedAttitude& f = pipe_->fusion().output();
          sol.has_fused = epochs_ > 0 && f.t == stars_->t && f.heads_used > 0;
          sol.q_I_B_fused = f.q_I_B;
          for (RowSink* s : sinks_)
            if (!s->writeStars(sol)) {
              error_ = s->error();
              return Result::kError;
            }
        }
        break;
      }
      case EpochAssembler::Out::kHeads:
        if (epochs_++ == 0) first_epoch_ = e.t;
        last_epoch_ = e.t;
        {
          if (hook_) hook_->beforeHeads(e);
          const Clock::time_point t0 = hook_ ? Clock::now() : Clock::time_point{};
          const core::Status st = pipe_->stepHeads(e);
          const double ns = hook_ ? nsSince(t0) : 0.0;
          const core::ValidHeads* valid = pipe_->lastValidHeads();
          if (!observers_.empty() && valid != nullptr) {
            // The epoch as the core's validator leaves it (the same checks, the same order of heads).
            const core::ValidHeads& v = *valid;
            core::HeadEpoch clean;
            clean.t = e.t;
            for (int s = 0; s < heads_cfg_.n_heads; ++s) {
              if (!v.has(s)) continue;
              core::HeadSample& h = clean.sample[static_cast<std::size_t>(clean.n++)];
              h.head_id = heads_cfg_.head[static_cast<std::size_t>(s)].id;
              h.q_I_Si = v.q_I_Si[static_cast<std::size_t>(s)];
              h.sigma_scale = v.sigma_scale[static_cast<std::size_t>(s)];
            }
            for (InputObserver* o : observers_) o->onHeads(clean, st);
          }
          if (hook_) hook_->afterStep(Sample::Kind::kHead, e.t, st, ns);
        }
        break;
      case EpochAssembler::Out::kAccel: {
        const Clock::time_point t0 = hook_ ? Clock::now() : Clock::time_point{};
        const core::Status st = pipe_->stepAcc(t, a);
        const double ns = hook_ ? nsSince(t0) : 0.0;
        for (InputObserver* o : observers_) o->onAcc(t, a, st);
        if (hook_) hook_->afterStep(Sample::Kind::kAccel, t, st, ns);
        break;
      }
      case EpochAssembler::Out::kPending:
        return drain() ? Result::kPending : Result::kError;
      case EpochAssembler::Out::kError: {
        const Source& s = *sources_[static_cast<std::size_t>(asm_.errorSource())];
        error_ = s.error().empty() ? s.name() + ": read failed" : s.error();
        return Result::kError;
      }
      case EpochAssembler::Out::kEnd: {
        pipe_->flush();
        for (InputObserver* o : observers_) o->onEnd();
        if (!drain()) return Result::kError;
        for (RowSink* s : sinks_)
          if (!s->end()) {
            error_ = s->error();
            return Result::kError;
          }
        finished_ = true;
        return Result::kDone;
      }
    }
    if (!drain()) return Result::kError;
  }
}

}  // namespace boresight::stream
