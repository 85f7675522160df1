// csm_datasheet: the datasheet one command regenerates, and the check that a committed one is
// current. For every preset and every filter over the default preset it measures shadow-map
// memory, misclassified pixels against the ray-traced truth, the error against the soft
// (sun-disk) truth, acne and leaks on the sample world's forest path, shimmer under
// translation, rotation and zoom at 0, 10^6 and 10^7 m, and (unless --check) the shadow and lit
// passes' GPU ms as medians of interleaved rounds. Writes datasheet.json, datasheet.md, two
// gnuplot PNGs and the README's headline table.
//   csm_datasheet                       regenerate tools/datasheet/results and README's table
//   csm_datasheet --check               the committed datasheet is current (exit 1 if not)
// See tools/datasheet/README.md.
#include <csm_measure/metrics.hpp>
#include <engine/errors.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "datasheet.hpp"
#include "datasheet_measure.hpp"
#include "tradeoff.hpp"

namespace datasheet {

namespace {

struct Cli {
  std::string out = CSM_SOURCE_DIR "/tools/datasheet/results";
  std::string readme = CSM_SOURCE_DIR "/README.md";
  bool check = false;
  bool timing = true;
  int rounds = 3;
  std::vector<std::string> rows;
  std::string report;  ///< --report FILE: the check's measurement as JSON
};

void usage(std::FILE* f) {
  std::fprintf(
      f,
      "usage: csm_datasheet [--out DIR] [--readme FILE] [--timing-rounds N] [--no-timing]\n"
      "       csm_datasheet --check [--out DIR] [--readme FILE] [--rows NAME,...] "
      "[--report FILE]\n"
      "  Regenerates DIR/datasheet.json, DIR/datasheet.md, DIR/datasheet_front.png,\n"
      "  DIR/datasheet_filters.png and the table between README's datasheet markers.\n"
      "  DIR defaults to the source tree's tools/datasheet/results, FILE to its README.md.\n"
      "  --timing-rounds N: interleaved timing rounds, median reported (default 3, [1, 20]).\n"
      "  --no-timing: the figures alone (ms columns '-').\n"
      "  --check: the quick form: DIR/datasheet.md and README's table are what\n"
      "  DIR/datasheet.json renders to (checked first, without measuring), and every figure\n"
      "  (not the timings) of the rows (--rows: only these) re-measured matches it within the\n"
      "  datasheet's tolerance. --report FILE: the re-measured figures as JSON.\n"
      "  Exit 0: current; 1: stale or edited (each difference printed); 2: bad arguments.\n");
}

std::vector<std::string> splitComma(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream in(s);
  for (std::string item; std::getline(in, item, ',');) {
    if (!item.empty()) out.push_back(item);
  }
  return out;
}

std::string readFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read " + path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

void writeFile(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
  if (!out) throw std::runtime_error("cannot write " + path);
}

// The two plots: the Pareto front of (shadow + lit ms, misclassified) over every row, and the
// shadow and lit ms of each filter over the default preset.
void writePlots(const nlohmann::json& sheet, const std::string& dir) {
  std::ofstream rows(dir + "/datasheet_rows.dat");
  std::ofstream front(dir + "/datasheet_front.dat");
  std::ofstream filters(dir + "/datasheet_filters.dat");
  std::vector<std::pair<double, double>> frontPoints;
  for (const nlohmann::json& r : sheet.at("rows")) {
    const nlohmann::json& t = r.at("timing");
    const double ms = t.at("shadow_ms").get<double>() + t.at("lit_ms").get<double>();
    const double mis = 100.0 * r.at("figures").at("misclassification").get<double>();
    std::string label = r.at("name").get<std::string>();
    for (char& c : label) c = c == ' ' ? '_' : c;
    rows << ms << " " << mis << " " << label << "\n";
    if (t.value("front", false)) frontPoints.push_back({ms, mis});
    if (r.at("preset") == "high") {
      filters << r.at("filter").get<std::string>() << " " << t.at("shadow_ms").get<double>() << " "
              << t.at("lit_ms").get<double>() << "\n";
    }
  }
  std::sort(frontPoints.begin(), frontPoints.end());
  for (const auto& [ms, mis] : frontPoints) front << ms << " " << mis << "\n";
  rows.close();
  front.close();
  filters.close();
  const std::string machine = sheet.at("machine").at("device").get<std::string>();
  csm_measure::runGnuplot(
      dir + "/datasheet_front.gp",
      "set terminal pngcairo size 900,560 noenhanced\n"
      "set output '" +
          dir +
          "/datasheet_front.png'\n"
          "set title 'Datasheet rows: GPU ms (shadow + lit pass, " +
          machine +
          ") against misclassified pixels'\n"
          "set xlabel 'shadow + lit pass ms (median of interleaved rounds, log scale)'\n"
          "set ylabel 'misclassified receiver pixels (%)'\n"
          // Log x: the prefiltered rows' full resolve costs ten times the others' frame.
          "set logscale x\nset offsets 0, graph 0.25, graph 0.05, 0\n"
          "set grid\nset key bottom left\n"
          "plot '" +
          dir +
          "/datasheet_front.dat' using 1:2 with lines lw 2 title 'Pareto front', "
          "'" +
          dir +
          "/datasheet_rows.dat' using 1:2 with points pt 7 ps 1.2 title 'rows', "
          "'' using 1:2:3 with labels offset 0.8,0.6 left font ',9' notitle\n");
  csm_measure::runGnuplot(
      dir + "/datasheet_filters.gp",
      "set terminal pngcairo size 900,480 noenhanced\n"
      "set output '" +
          dir +
          "/datasheet_filters.png'\n"
          "set title 'Cost per filter over the default preset (" +
          machine +
          ")'\n"
          "set ylabel 'GPU ms (median of interleaved rounds)'\n"
          "set style data histograms\nset style histogram rowstacked\n"
          "set style fill solid 0.8 border -1\nset boxwidth 0.6\nset grid ytics\n"
          "set key top left\n"
          "plot '" +
          dir +
          "/datasheet_filters.dat' using 2:xtic(1) title 'shadow pass', "
          "'' using 3 title 'lit pass'\n");
  for (const char* f : {"datasheet_rows.dat", "datasheet_front.dat", "datasheet_filters.dat",
                        "datasheet_front.gp", "datasheet_filters.gp"}) {
    std::filesystem::remove(dir + "/" + f);
  }
}

// The committed files agree with each other (no measurement): the differences, printed.
std::vector<std::string> checkConsistency(const Cli& cli, const nlohmann::json& committed) {
  std::vector<std::string> diffs =
      consistencyErrors(committed, readFile(cli.out + "/datasheet.md"), readFile(cli.readme));
  for (const std::string& d : diffs) std::printf("stale: %s\n", d.c_str());
  return diffs;
}

int compare(const Cli& cli, const nlohmann::json& committed, const nlohmann::json& measured) {
  const nlohmann::json& tol = committed.value("tolerance", nlohmann::json::object());
  const std::vector<std::string> diffs =
      compareFigures(committed, measured, tol.value("relative", kRelativeTolerance),
                     tol.value("absolute", kAbsoluteTolerance), cli.rows.empty());
  for (const std::string& d : diffs) std::printf("stale: %s\n", d.c_str());
  if (!diffs.empty()) {
    std::printf(
        "the committed datasheet does not match the code: regenerate it with build/bin/"
        "csm_datasheet (%zu difference(s))\n",
        diffs.size());
    return 1;
  }
  std::printf("the committed datasheet matches the code (%zu row(s) re-measured)\n",
              measured.at("rows").size());
  return 0;
}

int run(int argc, char** argv) {
  Cli cli;
  std::string command = "build/bin/csm_datasheet";
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) throw std::invalid_argument(a + " needs a value");
      return argv[++i];
    };
    if (a == "--out") {
      cli.out = next();
    } else if (a == "--readme") {
      cli.readme = next();
    } else if (a == "--check") {
      cli.check = true;
    } else if (a == "--no-timing") {
      cli.timing = false;
      command += " --no-timing";
    } else if (a == "--rows") {
      cli.rows = splitComma(next());
    } else if (a == "--report") {
      cli.report = next();
    } else if (a == "--timing-rounds") {
      const std::string v = next();
      const std::optional<int> n = tradeoff::parseTimingRounds(v);
      if (!n) {
        std::fprintf(stderr, "--timing-rounds %s is invalid: allowed an integer in [1, 20]\n",
                     v.c_str());
        return 2;
      }
      cli.rounds = *n;
      if (*n != 3) command += " --timing-rounds " + v;
    } else if (a == "--help" || a == "-h") {
      usage(stdout);
      return 0;
    } else {
      usage(stderr);
      return 2;
    }
  }
  if (!cli.check && !cli.rows.empty()) {
    std::fprintf(stderr, "--rows is for --check: the datasheet holds every row\n");
    return 2;
  }
  const auto start = std::chrono::steady_clock::now();
  auto elapsed = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  };
  MeasureOptions mo;
  mo.timing = cli.timing && !cli.check;
  mo.timingRounds = cli.rounds;
  mo.onlyRows = cli.rows;
  mo.command = command;
  if (cli.check) {
    // The committed files first: a missing or hand-edited file fails before measuring.
    const nlohmann::json committed = nlohmann::json::parse(readFile(cli.out + "/datasheet.json"));
    if (!checkConsistency(cli, committed).empty()) {
      std::printf("regenerate the datasheet with build/bin/csm_datasheet\n");
      return 1;
    }
    const nlohmann::json measured = measure(mo, elapsed);
    if (!cli.report.empty()) csm_measure::writeJson(cli.report, measured);
    const int rc = compare(cli, committed, measured);
    std::printf("(%.0f s)\n", elapsed());
    return rc;
  }
  const nlohmann::json sheet = measure(mo, elapsed);
  std::filesystem::create_directories(cli.out);
  csm_measure::writeJson(cli.out + "/datasheet.json", sheet);
  writeFile(cli.out + "/datasheet.md", renderMarkdown(sheet));
  writeFile(cli.readme, replaceReadmeBlock(readFile(cli.readme), headlineTable(sheet)));
  if (mo.timing) writePlots(sheet, cli.out);
  std::printf("%s\nwrote %s/datasheet.{json,md}%s and the table of %s (%.0f s)\n",
              headlineTable(sheet).c_str(), cli.out.c_str(),
              mo.timing ? ", datasheet_front.png, datasheet_filters.png" : "", cli.readme.c_str(),
              elapsed());
  return 0;
}

}  // namespace

}  // namespace datasheet

int main(int argc, char** argv) {
  return engine::runMain([&] { return datasheet::run(argc, argv); });
}
