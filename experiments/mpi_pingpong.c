/* One-way latency and bandwidth of the MPI transport a launch uses (OMPI_MCA_btl), between
 * ranks 0 and 1: the platform inputs of the simulated MPI validation
 * (platforms/smp2_mpi_*.xml). Half the median round trip of 8-byte and of 1 MiB messages.
 *   mpicc -O2 -o /tmp/mpi_pingpong experiments/mpi_pingpong.c
 *   OMPI_MCA_btl=self,vader mpirun -n 2 /tmp/mpi_pingpong                                 */
#include <mpi.h>
#include <stdio.h>
#include <stdlib.h>

static int cmp(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Median one-way seconds of `reps` round trips of `bytes`. */
static double one_way(int rank, char *buf, int bytes, int reps) {
    double *t = malloc(sizeof(double) * reps);
    for (int i = -reps / 10; i < reps; i++) {
        double t0 = MPI_Wtime();
        if (rank == 0) {
            MPI_Send(buf, bytes, MPI_CHAR, 1, 0, MPI_COMM_WORLD);
            MPI_Recv(buf, bytes, MPI_CHAR, 1, 0, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
        } else if (rank == 1) {
            MPI_Recv(buf, bytes, MPI_CHAR, 0, 0, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
            MPI_Send(buf, bytes, MPI_CHAR, 0, 0, MPI_COMM_WORLD);
        }
        if (i >= 0) t[i] = (MPI_Wtime() - t0) / 2;
    }
    qsort(t, reps, sizeof(double), cmp);
    double m = t[reps / 2];
    free(t);
    return m;
}

int main(int argc, char **argv) {
    MPI_Init(&argc, &argv);
    int rank;
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    const int big = 1 << 20;
    char *buf = calloc(big, 1);
    double lat = one_way(rank, buf, 8, 20000);
    double big_s = one_way(rank, buf, big, 200);
    if (rank == 0)
        printf("latency_s = %.9f\nbandwidth_Bps = %.0f\n", lat, big / (big_s - lat));
    free(buf);
    MPI_Finalize();
    return 0;
}
