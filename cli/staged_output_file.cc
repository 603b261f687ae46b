#include "staged_output_file.h"

#include "fleetmap/core/error.h"

namespace fleetmap::cli {
namespace {

// A failure of the file is the user's --out: name it so, with the file's own reason.
[[noreturn]] void ThrowForOut(const std::string& path, const Error& e) {
  throw Error(ErrorCode::kInvalidArgument, "cannot write --out " + path + ": " + e.message());
}

}  // namespace

StagedOutputFile::StagedOutputFile(const std::string& path) : path_(path) {
  try {
    file_.emplace(path);
  } catch (const Error& e) {
    ThrowForOut(path_, e);
  }
}

void StagedOutputFile::Commit() {
  try {
    file_->Commit();
  } catch (const Error& e) {
    ThrowForOut(path_, e);
  }
}

}  // namespace fleetmap::cli
