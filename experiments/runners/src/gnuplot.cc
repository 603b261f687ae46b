#include "fleetmap/runners/gnuplot.h"

#include <cstdlib>
#include <fstream>

namespace fleetmap {
namespace {

std::string ShellQuote(const std::string& s) {
  std::string quoted = "'";
  for (char c : s) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return quoted + "'";
}

}  // namespace

std::string GnuplotQuote(const std::string& s) {
  std::string quoted = "'";
  for (char c : s) quoted += c == '\'' ? std::string("''") : std::string(1, c);
  return quoted + "'";
}

std::string GnuplotPngPreamble(const std::filesystem::path& png_file, int width, int height) {
  const std::string size = std::to_string(width) + "," + std::to_string(height);
  return "if (strstrt(GPVAL_TERMINALS, 'pngcairo') > 0) {\n"
         "  set terminal pngcairo size " +
         size +
         " font ',10'\n"
         "} else {\n"
         "  set terminal png size " +
         size +
         "\n"
         "}\n"
         "set output " +
         GnuplotQuote(png_file.string()) + "\n";
}

bool RunGnuplot(const std::filesystem::path& script_file, const std::string& script,
                std::ostream& log) {
  std::ofstream out(script_file);
  out << script;
  out.close();
  if (!out) {
    log << "cannot write " << script_file.string() << ": no plot\n";
    return false;
  }
  if (std::system("command -v gnuplot > /dev/null 2>&1") != 0) {
    log << "gnuplot not found: " << script_file.string()
        << " written but not plotted (install gnuplot-nox)\n";
    return false;
  }
  const std::string command = "gnuplot " + ShellQuote(script_file.string()) + " 2>&1";
  if (std::system(command.c_str()) != 0) {
    log << "gnuplot failed on " << script_file.string() << ": no plot\n";
    return false;
  }
  return true;
}

}  // namespace fleetmap
