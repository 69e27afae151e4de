# The float lanes of the lattice cohesion's vectors (kCohesionFloatLanes, cohesion_grid.h) for a
# setting of WCH_COHESION_FLOAT_LANES: "8" or "16" as given; "auto" gives 8 on an AMD CPU of
# family 25 (Zen 4: AVX-512 on 256-bit units; docs/physics.md §7.3) when the build is for the
# build machine (native) and leaves the rest to the header (16 with AVX-512, 8 without): an
# empty result. Any other setting stops the configuration with a message that names it.
# cpuinfo: the file to read the CPU from (/proc/cpuinfo; test_cohesion_float_lanes passes others).
function(wch_cohesion_float_lanes setting native cpuinfo out)
  if(setting MATCHES "^(8|16)$")
    set(${out} ${setting} PARENT_SCOPE)
  elseif(NOT setting STREQUAL "auto")
    message(FATAL_ERROR "WCH_COHESION_FLOAT_LANES must be auto, 8 or 16, not '${setting}'")
  elseif(native AND EXISTS ${cpuinfo})
    file(STRINGS ${cpuinfo} vendor LIMIT_COUNT 1 REGEX "^vendor_id")
    file(STRINGS ${cpuinfo} family LIMIT_COUNT 1 REGEX "^cpu family")
    if(vendor MATCHES "AuthenticAMD" AND family MATCHES ":[ \t]*25$")
      set(${out} 8 PARENT_SCOPE)
    else()
      set(${out} "" PARENT_SCOPE)
    endif()
  else()
    set(${out} "" PARENT_SCOPE)
  endif()
endfunction()
