// bench_wkb.cpp: placeholder, written below.
int main() { return 0; }
