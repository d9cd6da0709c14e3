#include "tether/tools/folder_outputs.h"

#include <filesystem>
#include <ostream>

#include "tether/core/error.h"
#include "tether/core/output_file.h"
#include "tether/tools/command.h"
#include "tether/tools/commands.h"

namespace tether {

namespace fs = std::filesystem;

FolderOutputs::FolderOutputs(std::string dir) : dir_(std::move(dir)), set_(std::make_unique<OutputSet>()) {}
FolderOutputs::~FolderOutputs() = default;

int FolderOutputs::Fail(int code) const {
  std::error_code ignored;
  if (made_ && fs::is_empty(dir_, ignored)) fs::remove(dir_, ignored);
  return code;
}

int FolderOutputs::Prepare(const std::string& command, const std::vector<std::pair<std::string, std::string>>& inputs,
                           const std::vector<lidar::LidarOutput>& names, std::ostream& err) {
  std::error_code ec;
  made_ = !fs::exists(dir_, ec);
  fs::create_directories(dir_, ec);
  if (ec || !fs::is_directory(dir_)) {
    err << "tether " << command << ": cannot make the output folder '" << dir_ << "' (" << ec.message()
        << "); give a folder that can be written\n";
    return kExitWriteFailed;
  }
  const int rc = CheckOutputs(
      command, *set_,
      [&] {
        for (const auto& input : inputs) {
          if (input.second.empty()) {
            set_->AddInput(input.first);
          } else {
            set_->AddInput(input.first, input.second);
          }
        }
        for (const lidar::LidarOutput& f : names)
          files_.push_back(&set_->Add((fs::path(dir_) / f.name).string(), f.what));
      },
      err);
  return rc == kExitOk ? rc : Fail(rc);
}

int FolderOutputs::Write(const std::vector<lidar::LidarOutput>& files, std::ostream& err) {
  try {
    for (std::size_t i = 0; i < files.size() && i < files_.size(); ++i) files_[i]->Stage(files[i].bytes);
  } catch (const Error& e) {
    err << "error: " << e.what() << "; nothing was written\n";
    return kExitWriteFailed;
  }
  try {
    set_->CommitAll();  // all or nothing; its message says what became of the files
  } catch (const Error& e) {
    err << "error: " << e.what() << "\n";
    return kExitWriteFailed;
  }
  return kExitOk;
}

std::string FolderOutputs::List(const std::string& dir, const std::vector<lidar::LidarOutput>& names) {
  std::string s = dir + "/{";
  for (std::size_t i = 0; i < names.size(); ++i) s += (i > 0 ? ", " : "") + names[i].name;
  return s + "}";
}

}  // namespace tether
