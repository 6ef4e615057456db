/* The build's version (git describe of the tree it was built from) and how it was compiled, from the
 * header the Makefile writes into the build folder; only this file depends on it, so a new commit
 * recompiles one file. */
#include "version.h"

#include "commands.h"

const char *voxlab_version(void) { return VOXLAB_VERSION; }

const char *voxlab_build(void) { return VOXLAB_BUILD; }
