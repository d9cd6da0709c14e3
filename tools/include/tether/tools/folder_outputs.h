#pragma once
// The output folder of a command that writes several files (`tether lidar`, `tether mcl`): made
// where missing, its files checked before anything is read, and committed all or none at the
// end. A failed run removes a folder it made (still empty then).
//
//   FolderOutputs outputs(dir);
//   if (int rc = outputs.Prepare("mcl", {{log, ""}}, Front::OutputNames(), err); rc) return rc;
//   ... read, run; on an error: return outputs.Fail(rc);
//   if (int rc = outputs.Write(front.Outputs(), err); rc) return outputs.Fail(rc);
#include <iosfwd>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "tether/frontends/lidar/lidar_slam_2d.h"

namespace tether {

class OutputSet;
class OutputFile;

class FolderOutputs {
 public:
  explicit FolderOutputs(std::string dir);
  ~FolderOutputs();
  /// Makes the folder and names its files (`names`, in order), refusing any that would overwrite
  /// one of `inputs` (path, what; what may be empty); kExitOk, or the exit code after saying why
  /// on `err` (`command` names the command).
  int Prepare(const std::string& command, const std::vector<std::pair<std::string, std::string>>& inputs,
              const std::vector<lidar::LidarOutput>& names, std::ostream& err);
  /// Stages `files` (in the order Prepare named them) and commits them all or none; kExitOk or
  /// kExitWriteFailed after saying why.
  int Write(const std::vector<lidar::LidarOutput>& files, std::ostream& err);
  /// Removes the folder where this run made it and it is still empty; returns `code`.
  int Fail(int code) const;
  /// "DIR/{a, b, c}" for the report.
  static std::string List(const std::string& dir, const std::vector<lidar::LidarOutput>& names);

 private:
  std::string dir_;
  bool made_ = false;
  std::unique_ptr<OutputSet> set_;
  std::vector<OutputFile*> files_;
};

}  // namespace tether
