// csm_tradeoff: the CSV, the Pareto front, the table, the plot and the advice.
#include "tradeoff.hpp"

#include <csm/names.hpp>
#include <csm_measure/metrics.hpp>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace tradeoff {

std::vector<Row> readCsv(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("--replot: cannot read " + path);
  std::vector<Row> rows;
  std::string line;
  std::getline(in, line);  // header
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    std::vector<std::string> f;
    size_t p = 0;
    for (size_t q; (q = line.find(',', p)) != std::string::npos; p = q + 1) {
      f.push_back(line.substr(p, q - p));
    }
    f.push_back(line.substr(p));
    // 20 columns before the fit axes were added, 23 since, 24 with the soft error, 25 with the
    // fade (CSVs without it were measured with the hard cut).
    if (f.size() != 20 && f.size() != 23 && f.size() != 24 && f.size() != 25) {
      throw std::runtime_error("--replot: bad line in " + path + ": " + line);
    }
    Row r;
    r.config.cascades = uint32_t(std::stoul(f[0]));
    r.config.resolution = uint32_t(std::stoul(f[1]));
    r.config.lambda = std::stod(f[2]);
    const csm::Result<csm::PcfKernel> kernel = csm::parseKernel(f[3], "--replot: kernel");
    if (!kernel) throw std::runtime_error(kernel.error().message() + " in " + path);
    r.config.kernel = kernel.value();
    r.config.blendBand = std::stod(f[4]);
    // "d32" / "d16" (csm/names.hpp); CSVs written before the names were unified say "D32".
    const csm::Result<csm::DepthFormat> format = csm::parseDepthFormat(f[5], "--replot: format");
    if (!format) throw std::runtime_error(format.error().message() + " in " + path);
    r.config.format = csm::vk::toVkFormat(format.value());
    r.config.lods = f[6] == "1";
    r.shadowMs = std::stod(f[7]);
    r.litMs = std::stod(f[8]);
    r.cpuMs = std::stod(f[10]);
    r.memoryMiB = std::stod(f[11]);
    r.misclassification = std::stod(f[12]);
    r.meanError = std::stod(f[13]);
    r.shimmerMean = std::stod(f[14]);
    r.shimmerMax = std::stod(f[15]);
    r.triangles = std::stod(f[16]);
    r.pixels = std::stoull(f[17]);
    if (f.size() >= 23) {
      r.config.fit = f[20] == "tight" ? csm::BoxFit::kTight : csm::BoxFit::kSphere;
      r.config.ladderSteps = std::stod(f[21]);
      r.config.receivers = f[22] == "1" || f[22] == "2";
      r.config.histogram = f[22] == "2";
    }
    if (f.size() >= 24) r.softError = std::stod(f[23]);
    r.config.fade = f.size() >= 25 ? std::stod(f[24]) : 0.0;
    rows.push_back(r);
  }
  return rows;
}

void markParetoFront(std::vector<Row>& rows) {
  // Pareto front of (GPU ms, misclassification): no other row is at least as fast and as
  // accurate and strictly better in one.
  for (Row& r : rows) {
    r.pareto = std::none_of(rows.begin(), rows.end(), [&](const Row& q) {
      return q.gpuMs() <= r.gpuMs() && q.misclassification <= r.misclassification &&
             (q.gpuMs() < r.gpuMs() || q.misclassification < r.misclassification);
    });
  }
}

void writeCsv(const std::vector<Row>& rows, const std::string& csv) {
  std::ofstream f(csv);
  f << "cascades,resolution,lambda,kernel,blend_band,format,lods,shadow_gpu_ms,lit_gpu_ms,"
       "gpu_ms,cpu_ms,memory_mib,misclassification,mean_abs_error,shimmer_mean,shimmer_max,"
       "shadow_triangles,pixels,pareto,default,box_fit,ladder_steps,receiver_splits,"
       "mean_abs_error_soft,fade\n";
  for (const Row& r : rows) {
    const Config& c = r.config;
    char line[512];
    std::snprintf(line, sizeof line,
                  "%u,%u,%.2f,%s,%.2f,%s,%d,%.3f,%.3f,%.3f,%.3f,%.1f,%.5f,%.5f,%.3e,%.4f,%.0f,"
                  "%llu,%d,%d,%s,%.0f,%d,%.5f,%.3f\n",
                  c.cascades, c.resolution, c.lambda, csm::kernelName(c.kernel), c.blendBand,
                  csm::vk::depthFormatName(c.format), c.lods ? 1 : 0, r.shadowMs, r.litMs,
                  r.gpuMs(), r.cpuMs, r.memoryMiB, r.misclassification, r.meanError, r.shimmerMean,
                  r.shimmerMax, r.triangles, (unsigned long long)r.pixels, r.pareto ? 1 : 0,
                  c.isDefault() ? 1 : 0, c.fit == csm::BoxFit::kTight ? "tight" : "sphere",
                  c.ladderSteps, c.receivers ? (c.histogram ? 2 : 1) : 0, r.softError, c.fade);
    f << line;
  }
}

void printTable(const std::vector<Row>& rows, const std::string& info) {
  // Table on stdout (Markdown), Pareto rows marked.
  std::printf("%s\n\n", info.c_str());
  std::printf(
      "| cascades | resolution | lambda | kernel | band | format | LODs | shadow ms | lit ms | "
      "CPU ms | MiB | misclassified | mean err | soft err | shimmer max | shadow tris | fit | "
      "front |\n"
      "|---:|---:|---:|---|---:|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|---|\n");
  for (const Row& r : rows) {
    const Config& c = r.config;
    char soft[32] = "-";  // not measured (a CSV from before the column)
    if (r.softError >= 0.0) std::snprintf(soft, sizeof soft, "%.4f", r.softError);
    std::printf(
        "| %u | %u | %.2f | %s | %.2f | %s | %s | %.2f | %.2f | %.2f | %.0f | %.3f%% | %.4f | "
        "%s | %.4f | %.0f | %s | %s |\n",
        c.cascades, c.resolution, c.lambda, csm::kernelName(c.kernel), c.blendBand,
        csm::vk::depthFormatName(c.format), c.lodLabel().c_str(), r.shadowMs, r.litMs, r.cpuMs,
        r.memoryMiB, 100.0 * r.misclassification, r.meanError, soft, r.shimmerMax, r.triangles,
        c.fitLabel().empty() ? "-" : c.fitLabel().c_str() + 1,
        r.pareto ? (c.isDefault() ? "yes (default)" : "yes") : (c.isDefault() ? "(default)" : ""));
  }
}

void writePlot(const std::vector<Row>& rows, const std::string& out, const std::string& csv,
               const std::string& info) {
  // The plot: every configuration (LODs on filled, off hollow), the front (sorted by time) as a
  // labelled line, the defaults circled.
  {
    std::vector<const Row*> front;
    for (const Row& r : rows)
      if (r.pareto) front.push_back(&r);
    std::sort(front.begin(), front.end(),
              [](const Row* a, const Row* b) { return a->gpuMs() < b->gpuMs(); });
    std::ofstream f(out + "/tradeoff_front.dat");
    for (const Row* r : front) {
      f << r->gpuMs() << "," << 100.0 * r->misclassification << "," << r->config.shortLabel()
        << "\n";
    }
  }
  // CSV columns: 7 lods, 10 gpu_ms, 13 misclassification, 20 default; 'every ::1' skips the
  // header line.
  const std::string gp =
      "set datafile separator ','\nset terminal pngcairo size 1000,680 font 'sans,10'\n"
      "set output '" +
      out +
      "/tradeoff.png'\nset termoption noenhanced\n"
      "set title \"csm_tradeoff: GPU time vs misclassified receiver pixels (Embree truth)\\n" +
      info +
      "\"\nset xlabel 'GPU ms per frame (shadow pass + lit pass), log scale'\n"
      "set ylabel 'misclassified receiver pixels (%), log scale'\n"
      "set logscale xy\nset grid\nset key below horizontal\n"
      "plot '" +
      csv +
      "' every ::1 u ($7==1?$10:1/0):($13*100) w p pt 7 ps 0.8 lc rgb '#999999' "
      "t 'caster LODs on', '" +
      csv +
      "' every ::1 u ($7==0?$10:1/0):($13*100) w p pt 6 ps 0.8 lc rgb '#555555' "
      "t 'caster LODs off', '" +
      out +
      "/tradeoff_front.dat' u 1:2 w lp pt 7 ps 1.2 lw 2 lc rgb '#1f77b4' t 'Pareto front', '" +
      out +
      "/tradeoff_front.dat' u 1:2:(int($0)%2==0?stringcolumn(3):'') w labels left offset 0.8,0.6 "
      "font 'sans,8' tc rgb '#1f4f7f' notitle, '" +
      out +
      "/tradeoff_front.dat' u 1:2:(int($0)%2==1?stringcolumn(3):'') w labels right offset "
      "-0.8,-0.6 font 'sans,8' tc rgb '#1f4f7f' notitle, '" +
      csv +
      "' every ::1 u ($20==1?$10:1/0):($13*100) w p pt 6 ps 3 lw 3 lc rgb '#d62728' "
      "t 'default: " +
      Config{}.label() + "'\n";
  csm_measure::runGnuplot(out + "/tradeoff.gp", gp);
}

void printAdvice(const std::vector<Row>& rows, const std::vector<double>& budgetsMs,
                 const std::string& device) {
  const Row* defaultRow = nullptr;
  for (const Row& r : rows)
    if (r.config.isDefault()) defaultRow = &r;
  for (const double budget : budgetsMs) {
    const Row* best = nullptr;
    for (const Row& r : rows) {
      if (r.gpuMs() <= budget &&
          (!best || r.misclassification < best->misclassification ||
           (r.misclassification == best->misclassification && r.gpuMs() < best->gpuMs()))) {
        best = &r;
      }
    }
    if (!best) {
      std::printf("\n--budget-ms %.2f: no configuration fits; the fastest measured costs %.2f ms\n",
                  budget,
                  std::min_element(rows.begin(), rows.end(), [](const Row& a, const Row& b) {
                    return a.gpuMs() < b.gpuMs();
                  })->gpuMs());
      continue;
    }
    size_t fits = 0;
    for (const Row& r : rows) fits += r.gpuMs() <= budget;
    std::printf(
        "\n--budget-ms %.2f: recommend %s\n  why: of the %zu measured configurations that fit "
        "(GPU shadow + lit pass <= %.2f ms on %s), it misclassifies the fewest receiver pixels "
        "against the ray-traced truth (%.3f%%, mean error %.4f) at %.2f ms (shadow %.2f, lit "
        "%.2f), %.0f MiB of shadow maps, %.0f shadow triangles, CPU %.2f ms, stabilised shimmer "
        "max %.4f.\n",
        budget, best->config.label().c_str(), fits, budget, device.c_str(),
        100.0 * best->misclassification, best->meanError, best->gpuMs(), best->shadowMs,
        best->litMs, best->memoryMiB, best->triangles, best->cpuMs, best->shimmerMax);
    // What more accuracy would cost: the cheapest configuration that beats it.
    const Row* better = nullptr;
    for (const Row& r : rows) {
      if (r.misclassification < best->misclassification &&
          (!better || r.gpuMs() < better->gpuMs())) {
        better = &r;
      }
    }
    if (better) {
      std::printf("  more accuracy: %s misclassifies %.3f%% but costs %.2f ms (%.2f ms over).\n",
                  better->config.label().c_str(), 100.0 * better->misclassification,
                  better->gpuMs(), better->gpuMs() - budget);
    } else {
      std::printf("  it is the most accurate configuration measured.\n");
    }
    if (defaultRow && defaultRow != best) {
      std::printf("  the default (%s) costs %.2f ms and misclassifies %.3f%%%s.\n",
                  defaultRow->config.label().c_str(), defaultRow->gpuMs(),
                  100.0 * defaultRow->misclassification,
                  defaultRow->gpuMs() > budget ? ": it does not fit" : "");
    } else if (defaultRow) {
      std::printf("  it is the default.\n");
    }
  }
}

}  // namespace tradeoff
