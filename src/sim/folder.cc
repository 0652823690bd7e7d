// simulateIntoFolder: the one way a simulation becomes files (boresight simulate, the audit's
// simulation of its extended model).
#include <boresight/sim/output.h>
#include <boresight/sim/truth.h>

namespace boresight::sim {

bool simulateIntoFolder(Simulator& simulator, const std::string& dir, bool lcm, const std::vector<std::string>& effect_args,
                        const std::function<void(double)>& progress, std::vector<std::string>& files, std::string* error) {
  const Scenario& sc = simulator.scenario();
  lcm = lcm && sc.output.lcm_log;
  Level1Sink l1;
  LcmSink log;
  TeeSink tee;
  if (!l1.open(dir, sc, error)) return false;
  if (lcm && (!log.open(dir + "/sim.lcmlog", error) || !log.writeMountings(simulator))) {
    if (error && error->empty()) *error = dir + "/sim.lcmlog: cannot write the NOMINAL_MOUNTINGS message";
    return false;
  }
  tee.add(&l1);
  if (lcm) tee.add(&log);
  simulator.run(tee, progress);
  files = l1.files();
  const std::string qsa = dir + "/" + productFileName("QSA1B", sc);
  files.push_back(qsa);
  if (lcm) files.push_back(dir + "/sim.lcmlog");
  return l1.close(error) && (!lcm || log.close(error)) && writeQsa1b(qsa, simulator, error) &&
         writeTruthYaml(dir + "/truth.yaml", simulator, effect_args, files, error);
}

}  // namespace boresight::sim
