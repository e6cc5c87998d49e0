// layout.h: buffer layouts shared by host and kernels
