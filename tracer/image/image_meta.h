/* Provenance carried by an image file: string attributes ("voxlab:commit", "voxlab:command", ...)
 * written into EXR headers and read back by `voxlab compare --json`, so that an image on disk says
 * which build, command and inputs made it. */
#ifndef VX_IMAGE_META_H
#define VX_IMAGE_META_H

#define IMAGE_META_MAX 16
#define IMAGE_META_PREFIX "voxlab:"

typedef struct {
    char key[64];     /* with the IMAGE_META_PREFIX */
    char value[1024]; /* truncated when longer */
} image_meta_entry;

typedef struct {
    int count;
    image_meta_entry entry[IMAGE_META_MAX];
} image_meta;

/* Adds "voxlab:<name>" = the formatted value (ignored when the list is full). */
void image_meta_add(image_meta *m, const char *name, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
/* The command line as one string, arguments with spaces or quotes quoted for a POSIX shell. */
void image_meta_add_command(image_meta *m, int argc, char **argv);

#endif
