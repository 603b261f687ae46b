// Small text helpers the experiment reports share.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace fleetmap {

// `value` with `decimals` digits after the point; "-" for NaN.
std::string Fixed(double value, int decimals);

// The middle value (of an even count, the upper of the two middle ones); 0 for none.
double Median(std::vector<double> values);

// Writes `text` to `file`. Throws Error(kBackend) when it cannot.
void Save(const std::filesystem::path& file, const std::string& text);

}  // namespace fleetmap
