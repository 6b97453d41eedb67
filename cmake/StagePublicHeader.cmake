# Copies one public header from IN to OUT with its project includes rewritten to the installed <volcl/...> form.
# Usage: cmake -DIN=<source header> -DOUT=<staged header> -P StagePublicHeader.cmake
file(READ "${IN}" _text)
# host/ only groups the library's data domains in the source tree: installed, host/io/X.hpp is <volcl/io/X.hpp>.
string(REGEX REPLACE "#include \"host/([^\"]+)\"" "#include <volcl/\\1>" _text "${_text}")
string(REGEX REPLACE "#include \"((core|render|wavelet|preintegration|cl)/[^\"]+)\"" "#include <volcl/\\1>" _text "${_text}")
if(EXISTS "${OUT}")
  file(READ "${OUT}" _old)
  if(_old STREQUAL _text)
    return() # unchanged: keep the timestamp so consumers do not rebuild
  endif()
endif()
file(WRITE "${OUT}" "${_text}")
