# One place for warning flags: every esfleet target calls esfleet_warnings(target).
function(esfleet_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow -Wconversion
                                           -Wno-sign-conversion)
endfunction()
