#include <cstdio>
int main() {
  std::puts("usage: vismap render SCENE -o OUT");
  return 2;
}
