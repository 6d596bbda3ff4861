// The OBJ parser itself, compiled into the fuzz targets with their instrumentation (coverage and
// sanitizers): Debian's tinyobjloader ships its implementation in the header, so this unit's
// definitions take the place of the uninstrumented shared library's in the fuzz executables.
// (pugixml, the other parser the scene loader uses, ships no source: it stays a black box.)
#define TINYOBJLOADER_IMPLEMENTATION
#include <tiny_obj_loader.h>
