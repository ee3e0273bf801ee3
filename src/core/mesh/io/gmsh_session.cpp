#include "gmsh_session.hpp"

#include <gmsh.h>
#include <locale.h>
#include <stdlib.h>

#include <cerrno>
#include <clocale>
#include <cstring>
#include <exception>
#include <filesystem>
#include <new>
#include <system_error>
#include <utility>
#include <vector>

#include "mesh_file.hpp"
#include "tissue_cut/mesh/mesh_io.hpp"

namespace tissue_cut::mesh_io {
namespace {

std::mutex& gmshMutex() {
  static std::mutex mutex;
  return mutex;
}

// Guarded by gmshMutex().
bool gmsh_initialized = false;

locale_t cLocale() {
  static const locale_t locale = newlocale(LC_ALL_MASK, "C", static_cast<locale_t>(0));
  return locale;
}

}  // namespace

GmshSession::ThreadCLocale::ThreadCLocale() {
  if (cLocale() != static_cast<locale_t>(0)) previous_ = uselocale(cLocale());
}

GmshSession::ThreadCLocale::~ThreadCLocale() {
  if (previous_ != static_cast<locale_t>(0)) uselocale(previous_);
}

GmshSession::GmshSession(std::string file_name)
    : file_name_(std::move(file_name)), lock_(gmshMutex()) {
  run("start", [] {
    if (!gmsh_initialized) {
      // gmsh::initialize() sets the process-wide numeric locale to "C"; reading a mesh should
      // not change it for the rest of the program.
      const std::string process_locale = std::setlocale(LC_ALL, nullptr);
      // No config files: a user's ~/.gmsh-options must not change how meshes are read.
      gmsh::initialize(0, nullptr, false);
      std::setlocale(LC_ALL, process_locale.c_str());
      // Gmsh talks on stdout by default; a library reading a mesh should not.
      gmsh::option::setNumber("General.Terminal", 0);
      gmsh_initialized = true;
    }
    gmsh::clear();
  });
  run("set its options", [this] {
    setOption("General.Terminal", 0);
    setOption("General.NumThreads", 1);
  });
}

GmshSession::~GmshSession() {
  try {
    gmsh::clear();
  } catch (...) {
    // The model is cleared again before the next use; nothing useful to do here.
  }
  for (auto it = saved_options_.rbegin(); it != saved_options_.rend(); ++it) {
    try {
      gmsh::option::setNumber(it->first, it->second);
    } catch (...) {
      // It was read from Gmsh a moment ago, so it can be set; nothing to do if not.
    }
  }
}

void GmshSession::setOption(const std::string& name, double value) {
  double previous = 0;
  gmsh::option::getNumber(name, previous);
  saved_options_.emplace_back(name, previous);
  gmsh::option::setNumber(name, value);
}

void GmshSession::throwGmshFailure(const std::string& what) const {
  std::string detail;
  try {
    throw;
  } catch (const MeshIOError&) {
    throw;
  } catch (const std::string& message) {
    detail = message;
  } catch (const std::bad_alloc&) {
    detail = "out of memory";
  } catch (const std::exception& error) {
    detail = error.what();
  } catch (const char* message) {
    detail = message ? message : "";
  } catch (...) {
    detail = "unknown error";
  }
  if (detail.empty()) {
    try {
      gmsh::logger::getLastError(detail);
    } catch (...) {
    }
  }
  throwMeshIOError(file_name_, "", "Gmsh could not " + what + ": " + detail);
}

ScratchDirectory::ScratchDirectory(const std::string& file_name) {
  std::error_code error;
  std::filesystem::path base = std::filesystem::temp_directory_path(error);
  if (error) base = "/tmp";
  std::string pattern = (base / "tissue_cut_mesh_XXXXXX").string();
  std::vector<char> buffer(pattern.begin(), pattern.end());
  buffer.push_back('\0');
  if (!mkdtemp(buffer.data())) {
    throwMeshIOError(file_name, "",
                     "cannot make a scratch directory in " + base.string() +
                         " for Gmsh: " + std::strerror(errno));
  }
  directory_ = buffer.data();
}

ScratchDirectory::~ScratchDirectory() {
  std::error_code ignored;
  std::filesystem::remove_all(directory_, ignored);
}

}  // namespace tissue_cut::mesh_io
