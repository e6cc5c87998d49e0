#pragma once
namespace vismap::cli {
// `vismap decode FRAME [-o OUT.svg] [--json]`: reads a bin (FORMAT.md) or compact (COMPACT.md)
// frame, prints one JSON summary line; -o draws its triangles as SVG, --json prints every array.
int cmd_decode(int argc, char** argv);
}  // namespace vismap::cli
