/* The one header bindgen reads (see build.rs): Embree 4 when its headers are found, else Embree 3.
 * EMBREE_INCLUDE_DIR (passed as -I by build.rs) takes precedence over the system include paths. */
#if defined(__has_include)
#  if __has_include(<embree4/rtcore.h>)
#    include <embree4/rtcore.h>
#  elif __has_include(<embree3/rtcore.h>)
#    include <embree3/rtcore.h>
#  else
#    error "caustica: Embree headers not found (neither <embree4/rtcore.h> nor <embree3/rtcore.h>). Install the Debian package libembree-dev (apt-get install libembree-dev), set EMBREE_INCLUDE_DIR, or build with --no-default-features for the pure-Rust BVH."
#  endif
#else
#  error "caustica: the C preprocessor lacks __has_include; use a recent libclang (libclang-dev)."
#endif
