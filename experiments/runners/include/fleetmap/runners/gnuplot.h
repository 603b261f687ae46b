// Plots for experiment and benchmark reports: gnuplot scripts written beside their PNGs, so a
// figure can be restyled and redrawn by hand (`gnuplot FILE.gp`) without rerunning anything.
#pragma once

#include <filesystem>
#include <ostream>
#include <string>

namespace fleetmap {

// A gnuplot single-quoted string ('' inside stands for one quote).
std::string GnuplotQuote(const std::string& s);

// The lines that select a PNG terminal (pngcairo when present) of this size and set the output.
std::string GnuplotPngPreamble(const std::filesystem::path& png_file, int width, int height);

// Writes `script` to `script_file` and runs gnuplot on it. Returns false, saying why on `log`,
// when gnuplot is not installed, the script cannot be written, or gnuplot fails.
bool RunGnuplot(const std::filesystem::path& script_file, const std::string& script,
                std::ostream& log);

}  // namespace fleetmap
