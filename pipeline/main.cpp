// Entry point of the frontmesh executable; everything lives in pipeline/cli.
#include "pipeline/cli.h"

int main(int argc, char** argv) { return frontmesh::pipeline::run_cli(argc, argv); }
