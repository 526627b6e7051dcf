// Result files for viewers (docs/OUTPUT.md, "Viewers"): XDMF for ParaView and extended XYZ for
// OVITO, from the snapshots, failure snapshots and trajectories a result file holds.
#pragma once
#include <string>
#include <vector>

namespace loosepack {

enum class ExportFormat { Xdmf, Extxyz };

struct ExportSelection {
  int point = -1;  // this point only (-1: every point)
  int seed = -1;   // this seed index only (-1: every member with data)
};

// Writes the viewer files of `path` next to it (`<stem>_pNNNN_sK.xmf`, `..._trajectory.xmf`,
// or the same with .extxyz) and returns their paths. XDMF reads the disks, forces and
// trajectories from the result file itself; only the contacts as line segments (their ends,
// across the periodic seam and down to the floor), which the file does not hold, go into a
// file of each snapshot's own, `<stem>_pNNNN_sK[_failure]_contacts.h5`. Every file is built
// before the first is written, each written whole or not at all (replace_file). Throws
// std::invalid_argument for a point or seed the file does not have, DamagedResultFile
// (output.hpp) for data no run writes (a missing dataset, lengths that differ, a contact naming
// no disk), std::runtime_error when the file has nothing to export (no snapshots: run with
// --snapshots or observables.trajectory_every) or a file cannot be written.
std::vector<std::string> export_viewer_files(const std::string& path, ExportFormat format,
                                             const ExportSelection& selection = {});

}  // namespace loosepack
