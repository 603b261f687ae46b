// Small text helpers the experiment reports share.
#pragma once

#include <filesystem>
#include <string>

namespace fleetmap {

// `value` with `decimals` digits after the point; "-" for NaN.
std::string Fixed(double value, int decimals);

// Writes `text` to `file`. Throws Error(kBackend) when it cannot.
void Save(const std::filesystem::path& file, const std::string& text);

}  // namespace fleetmap
