# gonio::warnings — the warning set every gonio target links privately.
add_library(gonio_warnings INTERFACE)
add_library(gonio::warnings ALIAS gonio_warnings)
target_compile_options(gonio_warnings INTERFACE
  -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor -Wold-style-cast
  -Wcast-align -Woverloaded-virtual -Wimplicit-fallthrough -Wformat=2
  $<$<BOOL:${GONIO_WERROR}>:-Werror>)

if(GONIO_SANITIZE)
  add_compile_options(-fsanitize=address,undefined -fno-omit-frame-pointer
                      -fno-sanitize-recover=undefined)
  add_link_options(-fsanitize=address,undefined)
endif()
