// csm_tradeoff: the CSV, the Pareto front, the table, the plot and the advice.
#include "tradeoff.hpp"

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
    // 20 columns before the fit axes were added, 23 since.
    if (f.size() != 20 && f.size() != 23) {
      throw std::runtime_error("--replot: bad line in " + path + ": " + line);
    }
    Row r;
    r.config.cascades = uint32_t(std::stoul(f[0]));
    r.config.resolution = uint32_t(std::stoul(f[1]));
    r.config.lambda = std::stod(f[2]);
    bool known = false;
    for (csm::PcfKernel k :
         {csm::PcfKernel::k1Tap, csm::PcfKernel::kTent3, csm::PcfKernel::kTent5,
          csm::PcfKernel::kTent7, csm::PcfKernel::kPoisson16, csm::PcfKernel::kPcss}) {
      if (f[3] == csm::kernelName(k)) {
        r.config.kernel = k;
        known = true;
      }
    }
    if (!known) throw std::runtime_error("--replot: unknown kernel " + f[3]);
    r.config.blendBand = std::stod(f[4]);
    r.config.format = f[5] == "D16" ? VK_FORMAT_D16_UNORM : VK_FORMAT_D32_SFLOAT;
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
    if (f.size() == 23) {
      r.config.fit = f[20] == "tight" ? csm::BoxFit::kTight : csm::BoxFit::kSphere;
      r.config.ladderSteps = std::stod(f[21]);
      r.config.receivers = f[22] == "1";
    }
    rows.push_back(r);
  }
  return rows;
}

}  // namespace tradeoff
