// Cites docs/architecture.md section 7, which this tree lacks, and issue 3.
int main() { return 0; }
