// The ids one task of an experiment mints: with deterministic ids on, a DeterministicUuids
// scope named for the task (its kind and numbers) under the world's seed, so the task mints the
// same ids whichever worker thread runs it and whatever ran before; else nothing changes.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "fleetmap/core/uuid.h"

namespace fleetmap {

class TaskIds {
 public:
  TaskIds(bool deterministic, std::uint64_t seed, const std::string& task) {
    if (deterministic) scope_.emplace(seed, task);
  }

 private:
  std::optional<DeterministicUuids> scope_;
};

}  // namespace fleetmap
