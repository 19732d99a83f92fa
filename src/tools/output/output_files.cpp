#include "output/output_files.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>

namespace die_cushion_ident {

namespace {

std::string cannotWrite(const std::string& path, int error) {
  return "cannot write " + path + ": " + std::strerror(error);
}

// The file's data on the disk: a disk that fills while the kernel writes back delayed blocks says so only
// here (or at close), not at write().
void syncToDisk(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw WriteError(cannotWrite(path, errno));
  if (::fsync(fd) != 0) {
    const int error = errno;
    ::close(fd);
    throw WriteError(cannotWrite(path, error));
  }
  if (::close(fd) != 0) throw WriteError(cannotWrite(path, errno));
}

// The directory's entry of a renamed file on the disk as well; some file systems cannot sync a directory,
// which costs nothing but the crash safety of the names.
void syncDirectoryOf(const std::string& path) {
  const std::size_t slash = path.rfind('/');
  const std::string directory = slash == std::string::npos ? "." : slash == 0 ? "/" : path.substr(0, slash);
  const int fd = ::open(directory.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return;
  ::fsync(fd);
  ::close(fd);
}

}  // namespace

void closeChecked(std::ofstream& file, const std::string& path) {
  errno = 0;
  file.close();
  if (!file) {
    throw WriteError("cannot write " + path +
                     (errno ? std::string(": ") + std::strerror(errno) : std::string()) +
                     " (disk full or no permission?)");
  }
}

OutputFiles::~OutputFiles() {
  for (std::size_t i = renamed_; i < paths_.size(); ++i) std::remove((paths_[i] + kPartialSuffix).c_str());
}

std::string OutputFiles::add(const std::string& path) {
  paths_.push_back(path);
  const std::string temporary = path + kPartialSuffix;
  std::remove(temporary.c_str());  // a previous run's, killed before it could remove it
  return temporary;
}

void OutputFiles::commit() {
  for (std::size_t i = renamed_; i < paths_.size(); ++i) syncToDisk(paths_[i] + kPartialSuffix);
  for (; renamed_ < paths_.size(); ++renamed_) {
    const std::string& path = paths_[renamed_];
    if (std::rename((path + kPartialSuffix).c_str(), path.c_str()) != 0) {
      throw WriteError("cannot rename " + path + kPartialSuffix + " to " + path + ": " +
                       std::strerror(errno));
    }
  }
  if (!paths_.empty()) syncDirectoryOf(paths_.back());
}

void writeWholeFile(const std::string& path, const std::string& text) {
  OutputFiles files;
  {
    std::ofstream file(files.add(path), std::ios::binary);
    file << text;
    closeChecked(file, path);
  }
  files.commit();
}

}  // namespace die_cushion_ident
