/* placeholder: the data generator (owned by the data helper) */
int main(void) { return 0; }
