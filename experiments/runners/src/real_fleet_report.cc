// real-fleet's judgement and files (real_fleet_report.h, real_fleet_experiment.h).
#include "real_fleet_report.h"

#include <map>
#include <sstream>

#include "fleetmap/runners/gnuplot.h"
#include "report_text.h"

namespace fleetmap {
namespace {

namespace fs = std::filesystem;

std::string PartOfWhole(std::int64_t part, std::int64_t whole) {
  return std::to_string(part) + "/" + std::to_string(whole);
}

std::string HourText(double hour_h) {
  return Fixed(hour_h, 1) + " h";
}

// Line 1: every same-hour revisit adds <= 10 % of its frames.
AcceptanceLine RevisitLine(const std::vector<RealFleetForay>& forays) {
  std::string worst;
  int revisits = 0;
  bool pass = true;
  for (const RealFleetForay& f : forays) {
    if (f.first_at_hour) continue;
    ++revisits;
    const bool ok = 10 * f.merge_added <= f.frames;
    if (!ok || worst.empty()) {
      worst = "foray " + std::to_string(f.index) + " at " + HourText(f.hour_h) + ": " +
              PartOfWhole(f.merge_added, f.frames);
    }
    pass = pass && ok;
  }
  return {"same-hour revisits add <= 10 % of their frames as new nodes (" +
              std::to_string(revisits) + " revisits; " + (pass ? "e.g. " : "fails at ") +
              (worst.empty() ? "none" : worst) + ")",
          revisits > 0 && pass};
}

// Line 2: a condition the map localises < 50 % of gets nodes, and the next robot at that hour
// localises >= 95 %. A condition is met by the first foray at its hour (a revisit that does not
// localise fails through the first line's nodes or this line's next robot). The very first
// foray meets an empty map, which shows nothing about conditions: it is left out, and without
// any other such condition the line fails.
AcceptanceLine NewConditionLine(const std::vector<RealFleetForay>& forays) {
  std::ostringstream seen;
  int conditions = 0;
  bool pass = true;
  for (std::size_t k = 1; k < forays.size(); ++k) {
    const RealFleetForay& f = forays[k];
    if (!f.first_at_hour || f.copy_nodes == 0 || !(2 * f.localised_copy < f.frames)) continue;
    ++conditions;
    const RealFleetForay* next =
        k + 1 < forays.size() && forays[k + 1].hour_h == f.hour_h ? &forays[k + 1] : nullptr;
    const bool ok =
        f.merge_added > 0 && next != nullptr && 100 * next->localised_copy >= 95 * next->frames;
    pass = pass && ok;
    seen << (conditions > 1 ? "; " : "") << f.condition << " at " << HourText(f.hour_h)
         << ": map localised " << PartOfWhole(f.localised_copy, f.frames) << ", merge added "
         << f.merge_added << ", next robot "
         << (next ? PartOfWhole(next->localised_copy, next->frames) : std::string("none"));
  }
  return {
      "a condition under which the map localises < 50 % gets an experience, after which the "
      "next robot at that hour localises >= 95 % (" +
          (conditions == 0 ? std::string("no condition broke the map") : seen.str()) + ")",
      conditions > 0 && pass};
}

// Line 3: at every hour, the download localises >= 0.95 x the frames copy does.
AcceptanceLine DownloadLine(const std::vector<RealFleetForay>& forays) {
  std::map<double, std::pair<std::int64_t, std::int64_t>> by_hour;  // copy, download
  for (const RealFleetForay& f : forays) {
    by_hour[f.hour_h].first += f.localised_copy;
    by_hour[f.hour_h].second += f.localised_download;
  }
  std::ostringstream seen;
  bool pass = !by_hour.empty();
  for (const auto& [hour, counts] : by_hour) {
    pass = pass && 100 * counts.second >= 95 * counts.first;
    seen << (seen.tellp() > 0 ? "; " : "") << HourText(hour) << " " << counts.second << " vs "
         << counts.first;
  }
  return {
      "the download localises >= 0.95 x the frames copy does, at every hour (" + seen.str() + ")",
      pass};
}

void WriteCsv(const fs::path& csv, const std::vector<RealFleetDrive>& drives) {
  std::ostringstream out;
  out << "drive,foray,hour_h,weather,condition,first_at_hour,robot,frames,tracked,"
         "mean_landmarks,copy_nodes,copy_bytes,localised_copy,download_nodes,download_bytes,"
         "localised_download,built_nodes,pushed_nodes,merge_revision,merge_added\n";
  for (const RealFleetDrive& d : drives) {
    for (const RealFleetForay& f : d.forays) {
      out << d.name << ',' << f.index << ',' << Fixed(f.hour_h, 2) << ',' << WeatherName(f.weather)
          << ',' << f.condition << ',' << f.first_at_hour << ',' << f.robot << ',' << f.frames
          << ',' << f.tracked << ',' << Fixed(f.mean_landmarks, 1) << ',' << f.copy_nodes << ','
          << f.copy_bytes << ',' << f.localised_copy << ',' << f.download_nodes << ','
          << f.download_bytes << ',' << f.localised_download << ',' << f.built_nodes << ','
          << f.pushed_nodes << ',' << f.merge_revision << ',' << f.merge_added << '\n';
    }
  }
  Save(csv, out.str());
}

std::string DriveText(const RealFleetOptions& options, const RealFleetDrive& d) {
  std::ostringstream out;
  out << "## " << d.name << "\n\nData: " << d.dataset << "; " << d.pairs << " pairs, "
      << d.forays.size() << " forays; the head holds " << d.head_nodes << " nodes.\n\n"
      << "| foray | hour | condition | robot | frames | tracked | landmarks | copy: nodes, bytes, "
         "localised | "
      << options.download_policy
      << ": nodes, bytes, localised | built | MERGE added |\n"
         "|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const RealFleetForay& f : d.forays) {
    out << "| " << f.index << (f.first_at_hour ? "" : " (revisit)") << " | " << HourText(f.hour_h)
        << " | " << f.condition << " | " << f.robot << " | " << f.frames << " | "
        << PartOfWhole(f.tracked, f.frames > 0 ? f.frames - 1 : 0) << " | "
        << Fixed(f.mean_landmarks, 0) << " | " << f.copy_nodes << ", " << f.copy_bytes << ", "
        << PartOfWhole(f.localised_copy, f.frames) << " | " << f.download_nodes << ", "
        << f.download_bytes << ", " << PartOfWhole(f.localised_download, f.frames) << " | "
        << f.built_nodes << " | " << f.merge_added << " |\n";
  }
  out << "\n### Acceptance, " << d.name << "\n\n";
  for (const AcceptanceLine& line : d.acceptance) {
    out << "- " << (line.pass ? "PASS" : "FAIL") << ": " << line.text << "\n";
  }
  return out.str() + "\n";
}

// Localised share per foray against copy and the download, and the nodes MERGE added.
bool Plot(const fs::path& dir, const RealFleetResult& r, std::ostream& log) {
  std::ostringstream gp;
  gp << GnuplotPngPreamble(dir / "real_fleet.png", 1200, 350 * static_cast<int>(r.drives.size()))
     << "set datafile separator ','\nset multiplot layout " << r.drives.size() << ",1\n"
     << "set xlabel 'foray'\nset ylabel 'frames localised (%)'\nset yrange [0:105]\n"
     << "set y2label 'nodes MERGE added'\nset y2tics\nset ytics nomirror\nset key outside\n";
  for (const RealFleetDrive& d : r.drives) {
    const std::string when = "(strcol(1) eq " + GnuplotQuote(d.name) + " ? ";
    gp << "set title " << GnuplotQuote(d.name) << "\nplot "
       << GnuplotQuote((dir / "real_fleet.csv").string()) << " skip 1 using 2:" << when
       << "100*$13/$8 : 1/0) with linespoints title 'copy', '' skip 1 using 2:" << when
       << "100*$16/$8 : 1/0) with linespoints title 'download', '' skip 1 using 2:" << when
       << "$20 : 1/0) axes x1y2 with impulses lw 4 title 'MERGE added'\n";
  }
  gp << "unset multiplot\n";
  return RunGnuplot(dir / "real_fleet.gp", gp.str(), log);
}

}  // namespace

std::vector<AcceptanceLine> JudgeRealFleetDrive(const std::vector<RealFleetForay>& forays) {
  return {RevisitLine(forays), NewConditionLine(forays), DownloadLine(forays)};
}

void WriteRealFleetReport(const RealFleetOptions& options, RealFleetResult& result) {
  result.csv = options.out_dir / "real_fleet.csv";
  WriteCsv(result.csv, result.drives);
  std::ostringstream plot_log;
  result.plot =
      Plot(options.out_dir, result, plot_log) ? options.out_dir / "real_fleet.png" : fs::path();
  std::ostringstream out;
  out << "# real-fleet: robots drive real streets at different hours, push, merge, pull and "
         "localise\n\n"
      << "Each foray drives every " << options.hours.size() * options.forays_per_hour
      << "th pair of its drive (no foray sees an image another foray's map was built from) under "
         "the condition of its hour, rendered from the recorded daylight images "
         "(fleetmap/conditions). Before it builds, a probe pulls copy and "
      << options.download_policy
      << " for its mission's hour through fleetmap-agent and the foray localises against each, "
         "starting lost; then its robot pulls, builds with single-agent EBN on its own map and "
         "pushes; 'MERGE added' is the merge's revision.\n\n";
  for (const RealFleetDrive& d : result.drives) out << DriveText(options, d);
  out << "Per foray: real_fleet.csv; plot: "
      << (result.plot.empty() ? "not drawn (" + plot_log.str() + ")"
                              : std::string("real_fleet.png"))
      << ".\n";
  result.summary = out.str();
  result.summary_file = options.out_dir / "summary.md";
  Save(result.summary_file, result.summary);
}

}  // namespace fleetmap
