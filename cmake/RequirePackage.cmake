# ringsim_require(<Package> "<debian packages>" [find_package args...])
# find_package() that fails configuration with the Debian package to install.
macro(ringsim_require _pkg _debian)
  find_package(${_pkg} ${ARGN} QUIET)
  if(NOT ${_pkg}_FOUND)
    message(FATAL_ERROR
      "Required dependency '${_pkg}' was not found.\n"
      "On Debian 12 install it with:  apt-get install ${_debian}\n"
      "(README.md lists the full set-up command.)")
  endif()
  message(STATUS "ringsim: found ${_pkg}")
endmacro()
