/*
 * The imsynth command line: one cmd_<name>.c per subcommand, dispatched by main.c.
 *
 * Exit codes (every subcommand):
 *   0  success
 *   1  the work failed (bad input file, invalid graph, I/O error): message on stderr
 *   2  usage error (unknown option, missing argument): message and usage on stderr
 */
#ifndef IMSYNTH_CLI_H
#define IMSYNTH_CLI_H

enum { EXIT_OK = 0, EXIT_FAILURE_WORK = 1, EXIT_USAGE = 2 };

/* Each takes the arguments after the subcommand name (argv[0] is the subcommand). */
int cmd_eval_graph(int argc, char **argv);
int cmd_describe(int argc, char **argv);
int cmd_sample(int argc, char **argv);
int cmd_render(int argc, char **argv);

/* Prints "imsynth <sub>: <message>" to stderr. */
void cli_error(const char *sub, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
/* True if argv has -h or --help before any "--". */
int cli_wants_help(int argc, char **argv);

#endif
