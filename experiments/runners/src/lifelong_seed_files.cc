#include "lifelong_seed_files.h"

#include <algorithm>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "fleetmap/runners/gnuplot.h"
#include "lifelong_held_out.h"
#include "report_text.h"

namespace fleetmap::lifelong_internal {
namespace {

struct CsvArm {
  std::string name;  // the columns' prefix
  const std::vector<LifelongDay>* days;
};

// The CSV's header as a list, so the plot finds a column by its name, not by counting.
class Columns {
 public:
  void Add(const std::string& name) { names_.push_back(name); }
  // 1-based, as gnuplot counts. Throws std::logic_error for a column not written (a bug here).
  int Of(const std::string& name) const {
    const auto it = std::find(names_.begin(), names_.end(), name);
    if (it == names_.end()) throw std::logic_error("lifelong.csv has no column " + name);
    return static_cast<int>(it - names_.begin()) + 1;
  }
  std::string Header() const {
    std::string header;
    for (const std::string& name : names_) header += (header.empty() ? "" : ",") + name;
    return header + '\n';
  }

 private:
  std::vector<std::string> names_;
};

void AddArmCells(std::ostringstream& csv, const LifelongDay& day,
                 const std::vector<std::string>& maps) {
  csv << ',' << day.nodes_built << ',' << day.nodes_added << ',' << day.nodes_retired << ','
      << day.map_nodes << ',' << Fixed(static_cast<double>(day.map_bytes) / 1e6, 3);
  for (const std::string& map : maps) {
    const LifelongHeldOut* h = HeldOutIn(day, map);
    if (h == nullptr) {
      csv << ",,,,,,";
      continue;
    }
    csv << ',' << Fixed(h->mean_nodes, 1) << ',' << h->frames << ',' << h->not_localised << ','
        << h->beyond_10m << ',' << Fixed(Share(h->not_localised, h->frames), 5) << ','
        << Fixed(Share(h->beyond_10m, h->frames), 5);
  }
}

}  // namespace

void WriteLifelongSeedFiles(const LifelongResult& result, const LifelongOptions& options,
                            const std::filesystem::path& dir, std::ostream& log) {
  std::filesystem::create_directories(dir);
  std::vector<CsvArm> arms = {{"without", &result.days}};
  if (!result.retiring_days.empty()) arms.push_back({"with", &result.retiring_days});
  std::vector<std::string> maps = {"copy"};
  maps.insert(maps.end(), options.policies.begin(), options.policies.end());

  Columns columns;
  for (const char* name : {"day", "forays", "world_replaced"}) columns.Add(name);
  for (const CsvArm& arm : arms) {
    for (const char* name :
         {"_nodes_built", "_nodes_added", "_nodes_retired", "_map_nodes", "_map_mb"}) {
      columns.Add(arm.name + name);
    }
    for (const std::string& map : maps) {
      for (const char* name :
           {"_nodes", "_frames", "_not_localised", "_beyond_10m", "_not_localised_p", "_p10"}) {
        columns.Add(arm.name + "_" + map + name);
      }
    }
  }
  std::ostringstream csv;
  csv << columns.Header();
  for (std::size_t d = 0; d < result.days.size(); ++d) {
    const LifelongDay& day = result.days[d];
    csv << day.day << ',' << day.forays << ',' << day.world_replaced;
    for (const CsvArm& arm : arms) AddArmCells(csv, (*arm.days)[d], maps);
    csv << '\n';
  }
  const std::filesystem::path csv_file = dir / "lifelong.csv";
  Save(csv_file, csv.str());

  // Each arm its dash (without solid, with dashed), each map its colour.
  const std::string data = GnuplotQuote(csv_file.string());
  const auto curve = [&](const std::string& column, const std::string& style, std::size_t arm,
                         int colour, const std::string& title) {
    return data + " using 1:" + std::to_string(columns.Of(column)) + " with " + style +
           " lw 2 dt " + std::to_string(arm + 1) + " lc " + std::to_string(colour) + " title " +
           GnuplotQuote(title);
  };
  std::ostringstream gp;
  gp << GnuplotPngPreamble(dir / "lifelong.png", 1200, 1300) << "set datafile separator ','\n"
     << "set multiplot layout 3,1\nset key outside right\nset xlabel 'day'\n"
     // Fixed margins, so the panels' days line up whatever their keys' widths.
     << "set lmargin at screen 0.08\nset rmargin at screen 0.70\n"
     << "set title 'Map nodes at the head after each day'\nset ylabel 'nodes'\nplot ";
  for (std::size_t a = 0; a < arms.size(); ++a) {
    gp << (a == 0 ? "" : ", ")
       << curve(arms[a].name + "_map_nodes", "linespoints", a, 1, arms[a].name + " retirement");
  }
  gp << "\nset title 'The day''s change: nodes MERGE added and retired, landmarks the world "
        "replaced'\nset ylabel 'nodes'\nset y2label 'landmarks'\nset y2tics\nset ytics nomirror\n"
     << "plot ";
  for (std::size_t a = 0; a < arms.size(); ++a) {
    gp << curve(arms[a].name + "_nodes_added", "linespoints", a, 2,
                "added, " + arms[a].name + " retirement")
       << ", ";
  }
  if (arms.size() > 1) {
    gp << curve("with_nodes_retired", "linespoints", 1, 3, "retired, with retirement") << ", ";
  }
  gp << data << " using 1:" << columns.Of("world_replaced")
     << " axes x1y2 with impulses lw 4 lc 4 title 'world replaced (y2)'\n"
     << "unset y2tics\nunset y2label\nset ytics mirror\n"
     << "set title 'The next day held out: P(X > 10 m)'\nset ylabel 'P(X > 10 m)'\nplot ";
  for (std::size_t m = 0; m < maps.size(); ++m) {
    for (std::size_t a = 0; a < arms.size(); ++a) {
      gp << (m == 0 && a == 0 ? "" : ", ")
         << curve(arms[a].name + "_" + maps[m] + "_p10", "linespoints", a, static_cast<int>(m) + 1,
                  maps[m] + ", " + arms[a].name + " retirement");
    }
  }
  gp << "\nunset multiplot\n";
  RunGnuplot(dir / "lifelong.gp", gp.str(), log);
}

}  // namespace fleetmap::lifelong_internal
