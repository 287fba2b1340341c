/* main.c — the poolreps command line: parse options, build the configuration,
 * call one library command, print its one-line error, map status to exit. */
#include <getopt.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <time.h>
#include <unistd.h>

#include <gsl/gsl_errno.h>

#include "poolreps/cmd.h"
#include "poolreps/config.h"
#include "csvio_priv.h"

enum {
	O_SET = 256, O_SEED, O_VERSION, O_TRACE, O_TRAIN, O_TEST, O_TARGET, O_WEIGHT,
	O_LEAVES, O_RETURN, O_FEATURES, O_BASE, O_EPSILON, O_SUMMARY, O_STATE, O_ACTION,
	O_SAMPLE, O_GRID, O_SPLIT, O_MISSING, O_KEEP
};

static const struct option longopts[] = {
	{"help", no_argument, 0, 'h'},
	{"version", no_argument, 0, O_VERSION},
	{"set", required_argument, 0, O_SET},
	{"seed", required_argument, 0, O_SEED},
	{"trace", required_argument, 0, O_TRACE},
	{"train", required_argument, 0, O_TRAIN},
	{"test", required_argument, 0, O_TEST},
	{"target", required_argument, 0, O_TARGET},
	{"weight", required_argument, 0, O_WEIGHT},
	{"leaves", required_argument, 0, O_LEAVES},
	{"return", required_argument, 0, O_RETURN},
	{"features", required_argument, 0, O_FEATURES},
	{"base", required_argument, 0, O_BASE},
	{"epsilon", required_argument, 0, O_EPSILON},
	{"summary", required_argument, 0, O_SUMMARY},
	{"state", required_argument, 0, O_STATE},
	{"action", required_argument, 0, O_ACTION},
	{"sample", required_argument, 0, O_SAMPLE},
	{"grid", required_argument, 0, O_GRID},
	{"split", required_argument, 0, O_SPLIT},
	{"missing", required_argument, 0, O_MISSING},
	{"keep", no_argument, 0, O_KEEP},
	{0, 0, 0, 0}
};

typedef struct {
	const char *name;
	const char *options; /* the command-specific long options it accepts */
	int (*fn)(const pr_config *, const pr_cmd_args *, char *);
	const char *usage;
} command;

static const command commands[] = {
	{"run", "", pr_cmd_run,
	 "poolreps [run] CONFIG [-o DIR] [--set section.key=value]... [--seed N] [-q]\n"
	 "  Run the experiment a parameter file describes; write CSVs, figures' data and\n"
	 "  provenance into DIR (default: results/<experiment.name>; figures: results/sim)."},
	{"shoot", "trace,keep", pr_cmd_shoot,
	 "poolreps shoot [-c FILE] [-i IN.csv] [-o OUT.csv] [--trace TRACE.csv] [--keep]\n"
	 "  One shot per input row. Input columns x0,y0,x1,y1,...,vx,vy. Output columns\n"
	 "  x0,y0,... (final), pocket0,... (id or -1), hit, min_gap, reward, t_end, events.\n"
	 "  --keep copies the input columns in front; the final positions are then\n"
	 "  final_x0,final_y0,..."},
	{"forest", "train,test,target,weight,leaves", pr_cmd_forest,
	 "poolreps forest --train FILE --test FILE --target COLS [--weight COL] [--leaves FILE]\n"
	 "                [-o OUT.csv] [-c FILE] [--set forest.key=value]...\n"
	 "  Fit extra trees on the training CSV (inputs = every other column), predict the\n"
	 "  test CSV: one pred_<name> column per target. --leaves writes each test row's\n"
	 "  active leaf per tree. Timings and test MSE go to stderr."},
	{"reps", "return,features,base,epsilon,summary", pr_cmd_reps,
	 "poolreps reps --return COL --features LIST [--base COL] [--epsilon E]\n"
	 "              [--summary FILE] [-i IN.csv] [-o OUT.csv]\n"
	 "  REPS weights p for every input row; LIST is a comma list of columns or a\n"
	 "  prefix ending in '*'. --summary writes eta,dual,kl,ess,bound."},
	{"policy", "train,state,action,weight,sample,target", pr_cmd_policy,
	 "poolreps policy --train FILE --state COLS --action COLS --weight COL [--sample N]\n"
	 "                [--target COLS] [-i STATES.csv] [-o OUT.csv] [--set policy.key=value]...\n"
	 "  Fit the tree-LWR Gaussian policy; write mean and covariance (and N samples)\n"
	 "  for every state row of the input. policy.target = reward_state needs --target\n"
	 "  (the training rows' final reward-ball positions)."},
	{"config", "", NULL,
	 "poolreps config [-c FILE] [--set section.key=value]... [--seed N]\n"
	 "  Write the effective configuration (defaults, file, overrides) as INI to stdout."},
	{"merge", "", pr_cmd_merge,
	 "poolreps merge -o DIR RUN_DIR...\n"
	 "  Combine single-repetition or single-variant outputs into what one process\n"
	 "  would have written."},
	{"sweep", "grid,split,missing", pr_cmd_sweep,
	 "poolreps sweep CONFIG [--grid SECTION.KEY=V1,V2,...]... [--split repetition|variant|both]\n"
	 "               -o SWEEP_DIR      |      poolreps sweep --missing SWEEP_DIR\n"
	 "  Write jobs over every combination of the grid values: one `poolreps run` per\n"
	 "  grid point and repetition and/or variant (exp1: setting, exp3: policy), listed\n"
	 "  in SWEEP_DIR/jobs.txt and manifest.csv, with slurm.sbatch and parallel.sh to run\n"
	 "  them and point-N/config.ini per grid point. --missing prints the jobs that have\n"
	 "  not finished, to run again."},
	{"collect", "", pr_cmd_collect,
	 "poolreps collect SWEEP_DIR\n"
	 "  Merge every grid point's jobs into point-N/merged (as `merge` does) and write\n"
	 "  SWEEP_DIR/sweep_summary.csv: the grid values and the experiment's summary rows.\n"
	 "  Names the jobs not done if there are any."},
};
#define NCOMMANDS (sizeof commands / sizeof commands[0])

static void usage(FILE *fp, const command *cmd)
{
	size_t i;

	if (cmd) {
		fprintf(fp, "Usage: %s\n", cmd->usage);
	} else {
		fprintf(fp, "Usage: poolreps CONFIG | poolreps COMMAND [options]\n\nCommands:\n");
		for (i = 0; i < NCOMMANDS; ++i)
			fprintf(fp, "  %s\n", commands[i].usage);
	}
	fprintf(fp,
	        "\nOptions every command accepts:\n"
	        "  -c FILE              parameter file (INI)\n"
	        "  --set SECTION.KEY=V  override one parameter (repeatable)\n"
	        "  --seed N             master seed (experiment.seed)\n"
	        "  -i FILE, -o FILE     input (default stdin) and output (default stdout)\n"
	        "  -q                   quiet: no progress, no summary line\n"
	        "  -h, --help           this help; after a COMMAND, that command's usage\n"
	        "  --version            print the version and exit\n"
	        "\nExit codes: 0 ok, 1 bad usage or parameter, 2 I/O or malformed CSV,\n"
	        "  3 numerical failure, 4 out of memory, 130 interrupted.\n\n");
	pr_config_help(fp);
}

/* During a run, the first signal asks the loops to stop (they return
 * PR_EINTR and remove the staging folder). Otherwise, or on a second signal,
 * remove open temporary files and leave at once. */
static volatile sig_atomic_t graceful;

static void on_signal(int sig)
{
	static const char msg[] = "poolreps: interrupted: partial output files removed, "
	                          "complete files kept\n";
	ssize_t rc;

	(void)sig;
	if (graceful && !pr_interrupted) {
		pr_interrupted = 1;
		return;
	}
	pr_csvw_cleanup();
	rc = write(STDERR_FILENO, msg, sizeof msg - 1);
	(void)rc;
	_exit(130);
}

/* Progress on stderr: a bar with ETA on a terminal, else a plain line per 10 %. */
typedef struct {
	struct timespec t0;
	int tty, last_decile;
	int open; /* a bar is drawn and its line not ended */
	double last_draw;
} progress_state;

static void on_progress(void *user, long done, long total, const char *what)
{
	progress_state *p = user;
	struct timespec t;
	double el, frac = total > 0 ? (double)done / (double)total : 1.0, eta;
	int decile = (int)(frac * 10), i, fill = (int)(frac * 30);

	clock_gettime(CLOCK_MONOTONIC, &t);
	el = (double)(t.tv_sec - p->t0.tv_sec) + 1e-9 * (double)(t.tv_nsec - p->t0.tv_nsec);
	eta = frac > 0 ? el * (1 - frac) / frac : 0;
	if (p->tty) {
		if (el - p->last_draw < 0.1 && done < total)
			return;
		p->last_draw = el;
		fputc('\r', stderr);
		fputc('[', stderr);
		for (i = 0; i < 30; ++i)
			fputc(i < fill ? '#' : ' ', stderr);
		fprintf(stderr, "] %3.0f%% %s, %.0f s, ETA %.0f s  ", 100 * frac, what, el, eta);
		p->open = done < total;
		if (!p->open)
			fputc('\n', stderr);
	} else if (decile > p->last_decile) {
		p->last_decile = decile;
		fprintf(stderr, "poolreps: %s: %ld/%ld (%.0f%%), %.1f s elapsed, ETA %.0f s\n",
		        what, done, total, 100 * frac, el, eta);
	}
}

static int fail(const char *msg)
{
	fprintf(stderr, "poolreps: %s\n", msg);
	return 1;
}

static int option_allowed(const command *cmd, const char *opt)
{
	const char *p = strstr(cmd->options, opt);
	size_t n = strlen(opt);

	return p && (p == cmd->options || p[-1] == ',') && (p[n] == '\0' || p[n] == ',');
}

int main(int argc, char **argv)
{
	pr_cmd_args a;
	pr_config cfg;
	progress_state prog;
	const command *cmd = NULL;
	const char *config_path = NULL, *seed = NULL, *used[32];
	char err[PR_ERRLEN], msg[PR_ERRLEN + 64];
	char **orig, **sets, **grids;
	int nsets = 0, nused = 0, help = 0, c, rc, i;
	struct timespec t0, t1;
	clock_t c0 = clock();
	size_t j;

	clock_gettime(CLOCK_MONOTONIC, &t0);
	gsl_set_error_handler_off();
	signal(SIGINT, on_signal);
	signal(SIGTERM, on_signal);
	memset(&a, 0, sizeof a);
	/* getopt_long permutes argv: provenance records the order as typed */
	orig = calloc(3 * ((size_t)argc + 1), sizeof *orig);
	if (!orig)
		return fail("out of memory");
	memcpy(orig, argv, (size_t)argc * sizeof *orig);
	sets = orig + argc + 1;
	grids = sets + argc + 1;
	a.grid = grids;
	a.argc = argc;
	a.argv = orig;
	opterr = 0;
	while ((c = getopt_long(argc, argv, ":c:i:o:qh", longopts, NULL)) != -1) {
		const char *name = NULL;
		switch (c) {
		case 'c': config_path = optarg; break;
		case 'i': a.input = optarg; break;
		case 'o': a.output = optarg; break;
		case 'q': a.quiet = 1; break;
		case 'h': help = 1; break;
		case O_VERSION: printf("poolreps %s\n", pr_version()); free(orig); return 0;
		case O_SET: sets[nsets++] = optarg; break;
		case O_SEED: seed = optarg; break;
		case O_TRACE: a.trace = optarg; name = "trace"; break;
		case O_TRAIN: a.train = optarg; name = "train"; break;
		case O_TEST: a.test = optarg; name = "test"; break;
		case O_TARGET: a.target = optarg; name = "target"; break;
		case O_WEIGHT: a.weight = optarg; name = "weight"; break;
		case O_LEAVES: a.leaves = optarg; name = "leaves"; break;
		case O_RETURN: a.ret = optarg; name = "return"; break;
		case O_FEATURES: a.features = optarg; name = "features"; break;
		case O_BASE: a.base = optarg; name = "base"; break;
		case O_SUMMARY: a.summary = optarg; name = "summary"; break;
		case O_STATE: a.state = optarg; name = "state"; break;
		case O_ACTION: a.action = optarg; name = "action"; break;
		case O_GRID: grids[a.ngrid++] = optarg; name = "grid"; break;
		case O_SPLIT: a.split = optarg; name = "split"; break;
		case O_MISSING: a.missing = optarg; name = "missing"; break;
		case O_KEEP: a.keep = 1; name = "keep"; break;
		case O_EPSILON: {
			char *end;
			a.epsilon = strtod(optarg, &end);
			if (end == optarg || *end || !(a.epsilon > 0) || a.epsilon > 1e6) {
				snprintf(msg, sizeof msg, "--epsilon %.40s: must be a number > 0 and <= 1e6", optarg);
				free(orig);
				return fail(msg);
			}
			a.epsilon_set = 1;
			name = "epsilon";
			break;
		}
		case O_SAMPLE: {
			char *end;
			a.sample = strtol(optarg, &end, 10);
			if (end == optarg || *end || a.sample < 1 || a.sample > 1000000) {
				snprintf(msg, sizeof msg, "--sample %.40s: must be an integer in 1..1000000", optarg);
				free(orig);
				return fail(msg);
			}
			name = "sample";
			break;
		}
		case ':':
			snprintf(msg, sizeof msg, "option %s needs a value (see poolreps --help)", argv[optind - 1]);
			free(orig);
			return fail(msg);
		default:
			/* in a group such as -qZ, optind may not have moved past it yet */
			if (optopt)
				snprintf(msg, sizeof msg, "unknown option -%c (see poolreps --help)", optopt);
			else
				snprintf(msg, sizeof msg, "unknown option %s (see poolreps --help)", argv[optind - 1]);
			free(orig);
			return fail(msg);
		}
		if (name && nused < 32)
			used[nused++] = name;
	}

	/* The first operand names a command; anything else is a parameter file. */
	if (optind < argc) {
		for (j = 0; j < NCOMMANDS; ++j)
			if (strcmp(argv[optind], commands[j].name) == 0)
				cmd = &commands[j];
		if (cmd)
			++optind;
		else
			cmd = &commands[0];
	}
	if (help || !cmd) {
		usage(help ? stdout : stderr, cmd);
		free(orig);
		return help ? 0 : 1;
	}
	if (cmd->fn == pr_cmd_run) {
		if (optind < argc)
			config_path = argv[optind++];
		if (!config_path) {
			free(orig);
			return fail("run: no parameter file given (poolreps CONFIG)");
		}
	} else if (cmd->fn == pr_cmd_sweep && !a.missing && optind < argc) {
		config_path = argv[optind++];
	} else if (cmd->fn == pr_cmd_merge || cmd->fn == pr_cmd_collect) {
		a.ninputs = argc - optind;
		a.inputs = argv + optind;
		optind = argc;
	}
	if (optind < argc) {
		snprintf(msg, sizeof msg, "%s: unexpected argument '%.60s'", cmd->name, argv[optind]);
		free(orig);
		return fail(msg);
	}
	for (i = 0; i < nused; ++i) {
		if (!option_allowed(cmd, used[i])) {
			snprintf(msg, sizeof msg, "%s: option --%s does not apply (see poolreps %s --help)",
			         cmd->name, used[i], cmd->name);
			free(orig);
			return fail(msg);
		}
	}
	a.command = cmd->name;
	graceful = cmd->fn == pr_cmd_run || cmd->fn == pr_cmd_merge || cmd->fn == pr_cmd_sweep ||
	           cmd->fn == pr_cmd_collect;
	if (!a.quiet) {
		memset(&prog, 0, sizeof prog);
		prog.t0 = t0;
		prog.tty = isatty(STDERR_FILENO);
		prog.last_decile = -1;
		a.progress.fn = on_progress;
		a.progress.user = &prog;
	}

	pr_config_init(&cfg);
	rc = PR_OK;
	if (config_path)
		rc = pr_config_load(&cfg, config_path, err);
	for (i = 0; rc == PR_OK && i < nsets; ++i)
		rc = pr_config_set(&cfg, sets[i], err);
	if (rc == PR_OK && seed) {
		char buf[96];
		snprintf(buf, sizeof buf, "experiment.seed=%.60s", seed);
		rc = pr_config_set(&cfg, buf, err);
		if (rc)
			snprintf(err, sizeof err, "--seed %.60s: must be an integer in 0..4294967295", seed);
	}
	if (rc == PR_OK)
		rc = pr_config_validate(&cfg, err);
	if (rc == PR_OK && !cmd->fn) {
		rc = pr_config_write(&cfg, stdout);
		if (rc == PR_OK && fflush(stdout))
			rc = PR_EIO;
		if (rc)
			snprintf(err, sizeof err, "<stdout>: write error");
	} else if (rc == PR_OK) {
		rc = cmd->fn(&cfg, &a, err);
	}
	free(orig);
	/* an error must not land at the end of an unfinished bar */
	if (!a.quiet && prog.open)
		fputc('\n', stderr);
	if (rc != PR_OK) {
		fprintf(stderr, "poolreps: %s\n", err);
		return pr_exit_code(rc);
	}
	if (cmd->fn == pr_cmd_run && !a.quiet) {
		struct rusage ru;
		getrusage(RUSAGE_SELF, &ru);
		clock_gettime(CLOCK_MONOTONIC, &t1);
		fprintf(stderr, "poolreps: done: wall %.2f s, cpu %.2f s, peak memory %.1f MiB\n",
		        (double)(t1.tv_sec - t0.tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0.tv_nsec),
		        (double)(clock() - c0) / CLOCKS_PER_SEC, (double)ru.ru_maxrss / 1024.0);
	}
	return 0;
}
