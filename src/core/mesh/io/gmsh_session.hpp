// Access to the Gmsh library, which is one process-wide state machine.
#pragma once

#include <locale.h>

#include <mutex>
#include <string>
#include <utility>
#include <vector>

namespace tissue_cut::mesh_io {

/// Exclusive use of Gmsh for one file. Holds a process-wide mutex for its lifetime, initialises
/// Gmsh on first use (no terminal output, no user configuration files) and leaves the model
/// empty before and after, so no mesh outlives the call that read it.
class GmshSession {
 public:
  /// `file_name` starts the messages of errors Gmsh reports.
  explicit GmshSession(std::string file_name);
  ~GmshSession();
  GmshSession(const GmshSession&) = delete;
  GmshSession& operator=(const GmshSession&) = delete;

  /// Sets a numeric Gmsh option for this session only: the destructor puts the previous value
  /// back, so that other users of Gmsh in the process do not inherit it. Call inside run().
  void setOption(const std::string& name, double value);

  /// Runs Gmsh API calls, turning whatever Gmsh throws (it throws std::string messages) into
  /// MeshIOError "<file>: Gmsh could not <what>: <Gmsh's message>".
  template <typename Calls>
  void run(const std::string& what, Calls&& calls) {
    try {
      calls();
    } catch (...) {
      throwGmshFailure(what);
    }
  }

 private:
  [[noreturn]] void throwGmshFailure(const std::string& what) const;

  // Gmsh parses numbers with fscanf, which follows the locale: under a locale with decimal
  // commas it would misread every coordinate. This gives the calling thread the "C" locale for
  // the time of the session, without touching the locale of the rest of the process.
  class ThreadCLocale {
   public:
    ThreadCLocale();
    ~ThreadCLocale();
    ThreadCLocale(const ThreadCLocale&) = delete;
    ThreadCLocale& operator=(const ThreadCLocale&) = delete;

   private:
    locale_t previous_ = static_cast<locale_t>(0);
  };

  std::string file_name_;
  std::unique_lock<std::mutex> lock_;
  ThreadCLocale c_locale_;
  std::vector<std::pair<std::string, double>> saved_options_;
};

/// A private, freshly made directory for the files handed to Gmsh, removed with its content on
/// destruction. Private so that nothing else in it is read: Gmsh also merges "<file>.opt" when it
/// exists next to a file it opens, and such a file can run commands.
class ScratchDirectory {
 public:
  /// `file_name` starts the message when the directory cannot be made.
  explicit ScratchDirectory(const std::string& file_name);
  ~ScratchDirectory();
  ScratchDirectory(const ScratchDirectory&) = delete;
  ScratchDirectory& operator=(const ScratchDirectory&) = delete;

  std::string path(const std::string& file) const { return directory_ + "/" + file; }

 private:
  std::string directory_;
};

}  // namespace tissue_cut::mesh_io
