# gonio::warnings — the warning set every gonio target links privately.
add_library(gonio_warnings INTERFACE)
add_library(gonio::warnings ALIAS gonio_warnings)
target_compile_options(gonio_warnings INTERFACE
  -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor -Wold-style-cast
  -Wcast-align -Woverloaded-virtual -Wimplicit-fallthrough -Wformat=2
  $<$<BOOL:${GONIO_WERROR}>:-Werror>)

if(GONIO_FUZZ)
  # Every library is instrumented (coverage for libFuzzer, ASan and UBSan), so that the
  # fuzzers are guided by, and the sanitizers check, the parsers inside the libraries and
  # not only the fuzz targets' own code. libFuzzer's main is linked into the fuzz targets
  # only; the unit tests of the same build get the sanitizer runtime's no-op coverage hooks.
  add_compile_options(-fsanitize=fuzzer-no-link,address,undefined -fno-omit-frame-pointer
                      -fno-sanitize-recover=undefined)
  add_link_options(-fsanitize=address,undefined)
elseif(GONIO_SANITIZE)
  add_compile_options(-fsanitize=address,undefined -fno-omit-frame-pointer
                      -fno-sanitize-recover=undefined)
  add_link_options(-fsanitize=address,undefined)
endif()
