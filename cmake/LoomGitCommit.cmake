# Run at build time (core/CMakeLists.txt's loom_git_commit target), not at configure time, so that
# an incremental build's `loom version` and every output's loom_version name the commit built:
# writes OUTPUT defining LOOM_GIT_COMMIT (the short hash, "-dirty" when tracked files differ from
# it; empty outside a git checkout), touching it only when that changes so nothing recompiles.
# Usage: cmake -DSOURCE_DIR=... -DOUTPUT=... -P LoomGitCommit.cmake
execute_process(
  COMMAND git rev-parse --short HEAD
  WORKING_DIRECTORY ${SOURCE_DIR}
  OUTPUT_VARIABLE commit
  OUTPUT_STRIP_TRAILING_WHITESPACE
  RESULT_VARIABLE not_a_checkout
  ERROR_QUIET)
if(not_a_checkout)
  set(commit "")
else()
  # `git status`, not `git diff-index`: it compares contents where only a file's time changed.
  execute_process(
    COMMAND git status --porcelain --untracked-files=no
    WORKING_DIRECTORY ${SOURCE_DIR}
    OUTPUT_VARIABLE changes
    ERROR_QUIET)
  if(NOT changes STREQUAL "")
    string(APPEND commit "-dirty")
  endif()
endif()
file(WRITE ${OUTPUT}.new "#define LOOM_GIT_COMMIT \"${commit}\"\n")
execute_process(COMMAND ${CMAKE_COMMAND} -E copy_if_different ${OUTPUT}.new ${OUTPUT})
file(REMOVE ${OUTPUT}.new)
