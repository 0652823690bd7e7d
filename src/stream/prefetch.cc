// PrefetchSource: a source read on a worker thread, handed over in batches through a bounded queue.
#include <boresight/stream/sources.h>

#include <condition_variable>
#include <deque>
#include <mutex>
#include <exception>
#include <thread>

namespace boresight::stream {

struct PrefetchSource::Impl {
  struct Entry {
    Next n;
    Reject why;
    Sample s;
  };
  using Batch = std::vector<Entry>;
  std::size_t batch_size, max_batches;
  std::mutex m;
  std::condition_variable cv;
  std::deque<Batch> queue;
  std::vector<Batch> spare;  // consumed batches, reused by the worker
  bool stop = false, finished = false;
  std::string thrown;  ///< what the inner source threw (the worker then ends with kError)
  Batch current;
  std::size_t pos = 0;
  std::thread worker;

  void run(Source* src) {
    Batch b;
    for (;;) {
      {
        std::unique_lock<std::mutex> l(m);
        if (!spare.empty()) {
          b = std::move(spare.back());
          spare.pop_back();
        }
      }
      b.clear();
      b.reserve(batch_size);
      bool terminal = false;
      while (b.size() < batch_size) {
        Entry e{Next::kEnd, Reject::kMalformed, Sample{}};
        try {
          e.n = src->next(e.s, e.why);
        } catch (const std::exception& x) {  // never std::terminate on a worker thread: the run fails
          thrown = src->name() + ": " + x.what();
          e.n = Next::kError;
        }
        b.push_back(e);
        if (e.n != Next::kSample && e.n != Next::kRejected) {
          terminal = e.n != Next::kPending;
          break;
        }
      }
      std::unique_lock<std::mutex> l(m);
      cv.wait(l, [&] { return stop || queue.size() < max_batches; });
      if (stop) return;
      queue.push_back(std::move(b));
      b = Batch{};
      if (terminal) finished = true;
      cv.notify_all();
      if (terminal) return;
    }
  }
};

PrefetchSource::PrefetchSource(std::unique_ptr<Source> inner, std::size_t batch_size, std::size_t queue_batches)
    : inner_(std::move(inner)), impl_(std::make_unique<Impl>()) {
  impl_->batch_size = batch_size < 1 ? 1 : batch_size;
  impl_->max_batches = queue_batches < 1 ? 1 : queue_batches;
  impl_->worker = std::thread([this] { impl_->run(inner_.get()); });
}

PrefetchSource::~PrefetchSource() {
  {
    std::lock_guard<std::mutex> l(impl_->m);
    impl_->stop = true;
  }
  impl_->cv.notify_all();
  if (impl_->worker.joinable()) impl_->worker.join();
}

Source::Next PrefetchSource::next(Sample& out, Reject& why) {
  Impl& d = *impl_;
  if (d.pos >= d.current.size()) {
    std::unique_lock<std::mutex> l(d.m);
    if (!d.current.empty()) d.spare.push_back(std::move(d.current));
    d.current.clear();
    d.pos = 0;
    d.cv.wait(l, [&] { return !d.queue.empty(); });
    d.current = std::move(d.queue.front());
    d.queue.pop_front();
    d.cv.notify_all();
  }
  const Impl::Entry& e = d.current[d.pos];
  // A terminal entry stays in place: asking again gives it again.
  if (e.n == Next::kSample || e.n == Next::kRejected || e.n == Next::kPending) ++d.pos;
  if (e.n == Next::kSample) out = e.s;
  why = e.why;
  if ((e.n == Next::kEnd || e.n == Next::kError) && d.worker.joinable()) d.worker.join();
  return e.n;
}

std::string PrefetchSource::error() const {
  if (impl_->worker.joinable()) return {};
  return impl_->thrown.empty() ? inner_->error() : impl_->thrown;
}

std::vector<std::string> PrefetchSource::issues() const {
  return impl_->worker.joinable() ? std::vector<std::string>() : inner_->issues();
}

}  // namespace boresight::stream
