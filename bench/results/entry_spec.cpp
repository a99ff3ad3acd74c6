// One benchmark entry, typed (entry_spec.hpp).
#include "bench/results/entry_spec.hpp"

#include <utility>

namespace lockstep::bench {

std::string_view to_string(entry_kind kind) noexcept {
  switch (kind) {
    case entry_kind::c2c: return "c2c";
    case entry_kind::serial: return "serial";
    case entry_kind::barrier: return "barrier";
    case entry_kind::rk4: return "rk4";
    case entry_kind::overhead: return "overhead";
  }
  return "rk4";
}

std::string_view to_string(entry_unit unit) noexcept {
  switch (unit) {
    case entry_unit::step: return "step";
    case entry_unit::episode: return "episode";
    case entry_unit::one_way: return "one_way";
  }
  return "step";
}

entry_spec entry_spec::c2c_calibration() {
  entry_spec spec;
  spec.kind = entry_kind::c2c;
  spec.pin = platform::placement::compact;
  spec.threads = 2;
  return spec;
}

entry_spec entry_spec::serial_step(kernels::model_choice model) {
  entry_spec spec;
  spec.kind = entry_kind::serial;
  spec.pin = platform::placement::none;  // the benchmark thread, wherever it runs
  spec.threads = 1;
  spec.model = model;
  return spec;
}

entry_spec entry_spec::barrier_episode(std::string sync, platform::placement pin, unsigned threads) {
  entry_spec spec;
  spec.kind = entry_kind::barrier;
  spec.sync = std::move(sync);
  spec.pin = pin;
  spec.threads = threads;
  return spec;
}

entry_spec entry_spec::parallel_step(std::string sync, std::string layout, platform::placement pin, unsigned threads,
                                     kernels::model_choice model) {
  entry_spec spec;
  spec.kind = entry_kind::rk4;
  spec.sync = std::move(sync);
  spec.layout = std::move(layout);
  spec.pin = pin;
  spec.threads = threads;
  spec.model = model;
  return spec;
}

entry_spec entry_spec::overhead_side(bool accounting, std::string sync, std::string layout, platform::placement pin,
                                     unsigned threads, kernels::model_choice model) {
  entry_spec spec = parallel_step(std::move(sync), std::move(layout), pin, threads, model);
  spec.kind = entry_kind::overhead;
  spec.accounting = accounting;
  return spec;
}

entry_unit entry_spec::unit() const noexcept {
  switch (kind) {
    case entry_kind::c2c: return entry_unit::one_way;
    case entry_kind::barrier: return entry_unit::episode;
    case entry_kind::serial:
    case entry_kind::rk4:
    case entry_kind::overhead: break;
  }
  return entry_unit::step;
}

std::string_view entry_spec::time_counter() const noexcept {
  switch (unit()) {
    case entry_unit::one_way: return "one_way_ns";
    case entry_unit::episode: return "ns_per_episode";
    case entry_unit::step: break;
  }
  return "ns_per_step";
}

std::string entry_spec::name() const {
  const std::string tail = "/pin:" + std::string(platform::to_string(pin)) + "/threads:" + std::to_string(threads);
  const std::string model_segment = model.name_segment();
  switch (kind) {
    case entry_kind::c2c:
      return "c2c" + tail;
    case entry_kind::serial:
      return "rk4" + model_segment + "/serial";
    case entry_kind::barrier:
      return "barrier/sync:" + sync + tail;
    case entry_kind::rk4:
      return "rk4" + model_segment + "/sync:" + sync + "/layout:" + layout + tail;
    case entry_kind::overhead:
      return std::string("overhead") + model_segment + "/accounting:" + (accounting ? "on" : "off") + "/sync:" + sync +
             "/layout:" + layout + tail;
  }
  return {};
}

nlohmann::json entry_json(const entry_spec& spec) {
  const auto text_or_null = [](const std::string& text) {
    return text.empty() ? nlohmann::json(nullptr) : nlohmann::json(text);
  };
  return {{"kind", std::string(to_string(spec.kind))},
          {"sync", text_or_null(spec.sync)},
          {"layout", text_or_null(spec.layout)},
          {"pin", spec.kind == entry_kind::serial ? nlohmann::json(nullptr)
                                                   : nlohmann::json(std::string(platform::to_string(spec.pin)))},
          {"threads", spec.threads},
          {"model", spec.model.name()},
          {"masses", spec.model.masses},
          {"accounting", spec.accounting},
          {"unit", std::string(to_string(spec.unit()))}};
}

}  // namespace lockstep::bench
